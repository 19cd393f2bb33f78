// strandmesh particles SKELETON -o DIR: the particle clouds and strand curves as JSON (the
// debug dump of the particles and strands stages; formats in particles/dump.h and
// strands/dump.h).

#include <cstdio>
#include <filesystem>

#include "apps/cli/commands.h"
#include "apps/cli/skeleton_options.h"
#include "core/errors.h"
#include "core/file_io.h"
#include "core/log.h"
#include "particles/dump.h"
#include "particles/particles.h"
#include "particles/quality.h"
#include "strands/dump.h"
#include "strands/strands.h"

namespace sm::cli {
namespace {

void log_warnings(const Warnings& warnings) { print_warnings(warnings, log::level() == log::Level::verbose); }

std::string fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

}  // namespace

void add_particles_command(CLI::App& app, const GlobalOptions&) {
  add_command(app, "particles", "Compute the particle clouds and strands of a skeleton and dump them as JSON",
              [](CLI::App& sub) -> Action {
                struct Opts {
                  std::string input;
                  std::string output;
                  bool quality = false;
                  SkeletonParams skeleton;
                  ParticleParams particles;
                  StrandParams strands;
                };
                auto o = std::make_shared<Opts>();
                sub.add_option("SKELETON", o->input, "Skeleton file (.json or .swc)")->required();
                sub.add_option("-o,--output", o->output, "Output directory (particles.json, strands.json)")->required();
                sub.add_option("--spacing", o->particles.spacing, "Particle spacing s in metres (0 = derived)")
                    ->capture_default_str()
                    ->check(CLI::NonNegativeNumber);
                sub.add_option("--root-strands", o->particles.root_strands,
                               "Choose s so the root carries about this many strands (0 = derived rule)")
                    ->capture_default_str()
                    ->check(kNotNegative);
                sub.add_option("--max-root-strands", o->particles.max_root_strands,
                               "Cap on the root's strands for the derived spacing")
                    ->capture_default_str()
                    ->check(kNotNegative);
                sub.add_option("--min-particles", o->particles.min_particles, "Fewest particles in a tip (>= 3)")
                    ->capture_default_str()
                    ->check(kNotNegative);
                sub.add_option("--max-steps", o->particles.max_steps, "Relaxation steps per node at most")
                    ->capture_default_str()
                    ->check(kNotNegative);
                sub.add_option("--seed", o->particles.seed, "Random seed (tip patterns, new strands)")
                    ->capture_default_str()
                    ->check(kNotNegative);
                sub.add_flag("--quality", o->quality,
                             "Also print the quality measures (closest pairs, holes, neighbour losses)");
                add_skeleton_options(sub, o->skeleton);
                return [o] {
                  check_output_dir(o->output);
                  const SkeletonResult loaded = load_skeleton(o->input, o->skeleton);
                  const Skeleton& sk = loaded.skeleton;
                  ProgressBar bar(log::level() != log::Level::quiet);
                  Stopwatch watch;
                  const ParticleField field = compute_particles(
                      sk, o->particles, [&](std::string_view phase, double f) { bar.update(phase, f); });
                  const double particle_seconds = watch.lap();
                  const StrandSet strands = build_strands(sk, field, o->strands);
                  const double strand_seconds = watch.lap();
                  bar.finish();
                  log_warnings(field.stats.warnings);
                  log_warnings(strands.stats.warnings);
                  const std::filesystem::path dir(o->output);
                  std::error_code ec;
                  std::filesystem::create_directories(dir, ec);
                  if (ec) throw IoError(o->output + ": cannot create the output directory: " + ec.message());
                  write_file_atomically(dir / "particles.json", particles_to_json(sk, field));
                  write_file_atomically(dir / "strands.json", strands_to_json(sk, field, strands, o->strands));
                  const ParticleStats& st = field.stats;
                  log::info(std::to_string(st.nodes) + " nodes, " + std::to_string(st.strands) + " strands, " +
                            std::to_string(st.particles) + " particles (s = " + fixed(field.spacing * 1000, 3) +
                            " mm) in " + fixed(particle_seconds, 3) + " s (" +
                            fixed(double(st.particles) / std::max(particle_seconds, 1e-9) / 1e6, 2) +
                            " M particles/s), strands in " + fixed(strand_seconds, 3) + " s -> " + o->output);
                  std::string timings;
                  for (const auto& e : st.timings.entries) timings += " " + e.name + " " + fixed(e.seconds, 3);
                  log::verbose("particle timings (s):" + timings);
                  log::verbose("relaxed " + std::to_string(st.relaxed_nodes) + " nodes (" +
                               std::to_string(st.relaxed_particles) + " particles, " +
                               std::to_string(st.relaxation_steps) + " steps), " + std::to_string(st.new_strands) +
                               " new strands, " + std::to_string(st.unconverged_nodes) + " nodes at the step budget");
                  if (o->quality) {
                    const ParticleQuality q = measure_particles(sk, field);
                    std::printf(
                        "quality: max |p|/r %s, closest pair %s x local spacing (node %u), largest hole %s s "
                        "(node %u), neighbour losses %s%% of %zu (forks %s%%), strands with a loss %zu of %zu, "
                        "median nearest neighbour %s s\n",
                        fixed(q.max_radius_ratio, 3).c_str(), fixed(q.min_pair, 3).c_str(), q.min_pair_node.value,
                        fixed(q.max_hole, 3).c_str(), q.max_hole_node.value, fixed(100 * q.loss_fraction(), 2).c_str(),
                        q.neighbour_events, fixed(100 * q.fork_loss_fraction(), 2).c_str(), q.strands_with_loss,
                        field.strand_count(), fixed(q.median_nearest, 3).c_str());
                  }
                  return int(kOk);
                };
              });
}

}  // namespace sm::cli
