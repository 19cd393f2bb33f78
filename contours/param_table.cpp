// ContourParams' table (core/param_table.h): config key, range, unit and help of each field.

#include "contours/contours.h"

namespace sm {
namespace {

using C = ContourParams;

const ParamSpec<C> kFields[] = {
    {.key = "ring_edge", .field = &C::ring_edge, .range = {.min = 0}, .unit = "x neighbour distance",
     .help = "target loop edge length, slices matched to it (0 = legacy: every boundary strand, slice_step)",
     .slider = {0, 20}},
    {.key = "min_ring_vertices", .field = &C::min_ring_vertices, .range = {.min = 3}, .unit = "count",
     .help = "fewest vertices a loop keeps with ring_edge", .slider = {3, 32}},
    {.key = "resolution", .field = &C::resolution, .range = {.min = 0, .min_open = true}, .unit = "factor",
     .help = "scales ring resolution and slice spacing together (with ring_edge)", .slider = {0.1, 4}},
    {.key = "slice_step", .field = &C::slice_step, .range = {.min = 0, .min_open = true}, .unit = "x local radius",
     .help = "distance between consecutive slices along a branch", .slider = {0.05, 2}},
    {.key = "max_slices_per_edge", .field = &C::max_slices_per_edge, .range = {.min = 0}, .unit = "count",
     .help = "most slices on one edge away from forks (0 = no limit)", .slider = {0, 32}},
    {.key = "max_slice_aspect", .field = &C::max_slice_aspect, .range = {.min = 0}, .unit = "x ring edge",
     .help = "with ring_edge, thin twigs' slices at most this many of their shortest loop edges apart (0 = isotropic)",
     .slider = {0, 10}},
    {.key = "max_corner_cut", .field = &C::max_corner_cut, .range = {.min = 0}, .unit = "x node radius",
     .help = "at a bend, strips pass at most this far from the node, else it gets a loop", .slider = {0.01, 2}},
    {.key = "min_slice_step", .field = &C::min_slice_step, .range = {.min = 0}, .unit = "x neighbour distance",
     .help = "lower bound on the slice step", .slider = {0, 5}},
    {.key = "split_gap", .field = &C::split_gap, .range = {.min = 0, .min_open = true}, .unit = "x neighbour distance",
     .help = "bundles split where they are this far apart", .slider = {0.1, 5}},
    {.key = "thin_gap_radii", .field = &C::thin_gap_radii, .range = {.min = 0}, .unit = "x twig radius",
     .help = "at forks of twigs thinner than half a neighbour distance, the split gap in twig radii (0 = off)",
     .slider = {0, 5}},
    {.key = "fork_transition", .field = &C::fork_transition, .range = {.min = 0}, .unit = "x fork radius",
     .help = "above a fork, a bundle reaches its own round section within this distance", .slider = {0.1, 5}},
    {.key = "min_fused_length", .field = &C::min_fused_length, .range = {.min = 0}, .unit = "x fork radius",
     .help = "unseparated bundles are forced apart no nearer the fork than this", .slider = {0, 10}},
    {.key = "split_outside_tips", .field = &C::split_outside_tips,
     .help = "a thin tip outside its sibling's round cones splits off below the tip instead of being absorbed"},
    {.key = "split_nested_laterals", .field = &C::split_nested_laterals,
     .help = "a lateral inside a fused section (whorls) splits off as soon as it is apart from the rest"},
    {.key = "uncross_loops", .field = &C::uncross_loops,
     .help = "interior loops crossing a neighbouring loop of their tube are left out (bends within a radius)"},
    {.key = "uncross_tolerance", .field = &C::uncross_tolerance, .range = {.min = 0}, .unit = "x loop radius",
     .help = "how far a loop may reach behind its predecessor's plane before it counts as crossing",
     .slider = {0, 0.5}},
    {.key = "uncross_reach", .field = &C::uncross_reach, .range = {.min = 0}, .unit = "x loop radius",
     .help = "loops farther apart along the branch than this never count as crossing", .slider = {0, 30}},
    // (More than 64 halvings are below a double's precision.)
    {.key = "split_bisection_steps", .field = &C::split_bisection_steps, .range = {.min = 0, .max = 64},
     .unit = "count", .help = "bisection steps refining a split", .slider = {0, 30}},
    {.key = "concave_turn_degrees", .field = &C::concave_turn_degrees, .range = {.min = 0, .max = 180, .max_open = true},
     .unit = "degrees", .help = "angular walk: sharper concave turns drop the point (0 = hull)", .slider = {0, 90}},
    {.key = "fallback_max_edge", .field = &C::fallback_max_edge, .range = {.min = 0}, .unit = "x neighbour distance",
     .help = "concave fallback for non-star-shaped slices: longer outline edges are carved (0 = convex hull)",
     .slider = {0, 10}},
};

}  // namespace

const ParamTable<ContourParams>& param_table(std::type_identity<ContourParams>) {
  static const ParamTable<ContourParams> t{"contours", kFields};
  return t;
}

}  // namespace sm
