// ParticleParams' table (core/param_table.h): config key, range, unit and help of each field.
// Lengths are relative to lambda, the cloud length (the particle spacing in the cross-section).

#include "particles/particles.h"

namespace sm {
namespace {

using P = ParticleParams;
constexpr double kMaxRoot = ParticleParams::kMaxRootStrands;

const ParamSpec<P> kFields[] = {
    {.key = "spacing", .field = &P::spacing, .range = {.min = 0}, .unit = "m",
     .help = "particle spacing s (0 = derived from root_strands or the rule)", .slider = {0, 0.05}},
    {.key = "root_strands", .field = &P::root_strands, .range = {.min = 0, .max = kMaxRoot}, .unit = "count",
     .help = "with spacing 0: choose s so the root has about this many strands (0 = rule)", .slider = {0, 20000}},
    {.key = "max_root_strands", .field = &P::max_root_strands, .range = {.min = 1, .max = kMaxRoot}, .unit = "count",
     .help = "upper bound on the root's strands for the derived spacing", .slider = {10, 100000, true}},
    {.key = "min_particles", .field = &P::min_particles,
     .range = {.min = 3, .max = ParticleParams::kMaxMinParticles}, .unit = "count",
     .help = "fewest particles in a tip cloud", .slider = {3, 50}},
    {.key = "new_strand_sparsity", .field = &P::new_strand_sparsity, .range = {.min = 1}, .unit = "x s",
     .help = "clouds sparser than this get new strands", .slider = {1, 4}},
    {.key = "wall_margin", .field = &P::wall_margin, .range = {.min = 0, .max = 1.5, .max_open = true},
     .unit = "x lambda", .help = "gap between the confining disc and the node radius", .slider = {0, 1.5}},
    {.key = "wall_offset", .field = &P::wall_offset, .range = {.min = 0}, .unit = "x lambda",
     .help = "soft wall: particles are repelled by mirror images this far outside the disc", .slider = {0, 2}},
    {.key = "max_steps", .field = &P::max_steps, .range = {.min = 0}, .unit = "count",
     .help = "relaxation: largest number of steps per node", .slider = {0, 400}},
    {.key = "move_tolerance", .field = &P::move_tolerance, .range = {.min = 0}, .unit = "x lambda",
     .help = "relaxation stops below this largest move", .slider = {0.001, 0.5, true}},
    {.key = "max_velocity", .field = &P::max_velocity, .range = {.min = 0, .min_open = true}, .unit = "x lambda",
     .help = "largest move per step", .slider = {0.01, 1}},
    {.key = "damping", .field = &P::damping, .range = {.min = 0, .max = 1, .max_open = true},
     .help = "fraction of the previous step's velocity kept", .slider = {0, 0.95}},
    {.key = "step_size", .field = &P::step_size, .range = {.min = 0, .min_open = true}, .unit = "x lambda",
     .help = "move per step per unit of repulsion", .slider = {0.01, 1}},
    {.key = "repulsion_radius", .field = &P::repulsion_radius, .range = {.min = 0, .min_open = true},
     .unit = "x lambda", .help = "particles repel within this distance", .slider = {1, 5}},
    {.key = "neighbour_skin", .field = &P::neighbour_skin, .range = {.min = 0, .min_open = true}, .unit = "x lambda",
     .help = "neighbour lists hold the pairs within repulsion_radius + this", .slider = {0.05, 2}},
    {.key = "rebuild_every", .field = &P::rebuild_every, .range = {.min = 1}, .unit = "count",
     .help = "neighbour lists rebuilt at least every k steps", .slider = {1, 20}},
    {.key = "fork_gap", .field = &P::fork_gap, .range = {.min = 0}, .unit = "x lambda",
     .help = "empty band between the two child bundles at a fork", .slider = {0, 3}},
    {.key = "max_total_particles", .field = &P::max_total_particles, .range = {.min = 0}, .unit = "count",
     .help = "upper bound on the total particle count; more is rejected before allocating",
     .slider = {1000, 5e8, true}},
    {.key = "seed", .field = &P::seed, .range = {.min = 0}, .help = "random seed (tip patterns, new strands)",
     .slider = {0, 1000}},
};

}  // namespace

const ParamTable<ParticleParams>& param_table(std::type_identity<ParticleParams>) {
  static const ParamTable<ParticleParams> t{"particles", kFields};
  return t;
}

}  // namespace sm
