#include "pipeline/pipeline.h"

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/file_io.h"
#include "contours/dump.h"
#include "core/mesh.h"
#include "particles/dump.h"
#include "skeleton/io.h"
#include "strands/dump.h"

namespace sm {

const char* stage_name(Stage s) {
  switch (s) {
    case Stage::skeleton: return "skeleton";
    case Stage::particles: return "particles";
    case Stage::strands: return "strands";
    case Stage::contours: return "contours";
    case Stage::meshing: return "meshing";
  }
  return "?";
}

Warnings PipelineResult::warnings() const {
  Warnings w;
  w.merge(skeleton.report.warnings);
  w.merge(particles.stats.warnings);
  w.merge(strands.stats.warnings);
  w.merge(contours.stats.warnings);
  w.merge(mesh.stats.warnings);
  w.merge(repair.warnings);
  return w;
}

void release_intermediates(PipelineResult& r) {
  // Swapped with empty vectors: clear() would keep the capacity.
  std::vector<dvec3>().swap(r.strands.point);
  std::vector<dvec3>().swap(r.contours.point);
  std::vector<StrandId>().swap(r.contours.strand);
}

namespace {

/// Warns (`thick_nodes_outside`, naming them) of the thick skeleton nodes the near-miss push
/// left outside the mesh (NearMissStats::left) that are still outside the final mesh (tested
/// again where the outer surface replaced it). Nothing when meshing.cover_near_misses is off,
/// which is where they are found on every mesh size.
void warn_thick_nodes_outside(PipelineResult& r) {
  const Skeleton& s = r.skeleton.skeleton;
  std::vector<NodeId> left = r.near_misses.left;
  if (!left.empty() && r.outer_surface.applied) {
    std::vector<glm::dvec3> at;
    for (const NodeId n : left) at.push_back(s.position[n.idx()]);
    const std::vector<std::uint8_t> inside = inside_closed_mesh(r.mesh.mesh, at);
    std::vector<NodeId> still;
    for (std::size_t k = 0; k < left.size(); ++k) {
      if (!inside[k]) still.push_back(left[k]);
    }
    left = std::move(still);
  }
  for (const NodeId n : left) {
    r.mesh.stats.warnings.add("thick_nodes_outside",
                              "skeleton node at least the median radius thick left outside the mesh (after the "
                              "fork retry, the near-miss push and the outer surface)",
                              s.describe(n));
  }
}

}  // namespace

void rerun_pipeline(PipelineResult& r, const RawSkeleton& raw, const PipelineParams& p, Stage from,
                    const ProgressFn& progress) {
  auto report = [&](std::string_view phase, double f) {
    if (progress) progress(phase, f);
  };
  // Parameters out of range fail before any stage runs (the particle stage checks its own).
  validate_params(p.contours);
  validate_params(p.meshing);
  validate_params(p.repair);
  Stopwatch clock;
  auto timed = [&](Stage s, auto&& fn) {
    if (from > s) return;
    clock.lap();
    fn();
    for (auto& e : r.timings.entries) {
      if (e.name == stage_name(s)) e.seconds = 0;
    }
    r.timings.add(stage_name(s), clock.lap());
  };
  timed(Stage::skeleton, [&] {
    report("skeleton", 0);
    r.skeleton = build_skeleton(raw, p.skeleton);
    if (r.skeleton.skeleton.size() < 2) {
      throw InvalidInputError(raw.source + ": the skeleton has a single node after sanitizing; a tree needs at least "
                                           "one edge to be meshed");
    }
  });
  timed(Stage::particles, [&] { r.particles = compute_particles(r.skeleton.skeleton, p.particles, progress); });
  timed(Stage::strands, [&] {
    report("strands", 0);
    r.strands = build_strands(r.skeleton.skeleton, r.particles, p.strands);
  });
  timed(Stage::contours,
        [&] { r.contours = compute_contours(r.skeleton.skeleton, r.particles, r.strands, p.contours, progress); });
  timed(Stage::meshing, [&] { r.mesh = build_mesh(r.skeleton.skeleton, r.contours, p.meshing, progress); });
  // (Its runs add their own times to the contours and meshing stages.)
  r.fork_retry = retry_forks(r, p, progress);
  // (Their times count as meshing.)
  r.near_misses = cover_near_misses(r.mesh, r.skeleton.skeleton, p.meshing);
  r.timings.add(stage_name(Stage::meshing), r.near_misses.seconds);
  const bool nodes_outside =
      r.fork_retry.outside_after > 0 && (!r.near_misses.tried || r.near_misses.outside_after > 0);
  report("outer surface", 0);
  r.outer_surface = keep_outer_surface(r.mesh, r.skeleton.skeleton, p.meshing, nodes_outside);
  r.timings.add(stage_name(Stage::meshing), r.outer_surface.seconds);
  // The repair stage: what the fork retry and the outer surface left is fused by the union.
  report("repair", 0);
  r.repair = repair_mesh(r.mesh, r.skeleton.skeleton, p.repair);
  r.timings.add("repair", r.repair.timings.total());
  warn_self_intersections_left(r);
  warn_thick_nodes_outside(r);
}

PipelineResult run_pipeline(const RawSkeleton& raw, const PipelineParams& params, const ProgressFn& progress) {
  PipelineResult r;
  rerun_pipeline(r, raw, params, Stage::skeleton, progress);
  return r;
}

std::string stats_to_json(const PipelineResult& r, double export_seconds, double total_seconds) {
  using nlohmann::json;
  json seconds;
  for (const char* s : {"skeleton", "particles", "strands", "contours", "meshing"}) seconds[s] = r.timings.get(s);
  seconds["export"] = export_seconds;
  seconds["total"] = total_seconds > 0 ? total_seconds : r.timings.total() + export_seconds;
  json warnings = json::array();
  const Warnings all = r.warnings();
  for (const auto& w : all.list()) {
    warnings.push_back({{"kind", w.kind}, {"message", w.message}, {"count", w.count}, {"examples", w.examples}});
  }
  const json j{{"nodes", r.skeleton.skeleton.size()},
               {"input_nodes", r.skeleton.report.input_nodes},
               {"sanitizing",
                {{"dropped_nodes", r.skeleton.report.dropped_nodes},
                 {"max_move_m", r.skeleton.report.max_move},
                 {"max_move_radii", r.skeleton.report.max_move_radii},
                 {"p95_move_radii", r.skeleton.report.p95_move_radii},
                 {"raised_radii", r.skeleton.report.raised_radii},
                 {"clamped_radii", r.skeleton.report.clamped_children}}},
               {"strands", r.particles.strand_count()},
               {"particles", r.particles.position.size()},
               {"spacing", r.particles.spacing},
               {"slices", r.contours.loop_count()},
               {"junctions", r.contours.junctions.size()},
               {"vertices", r.mesh.mesh.vertex_count()},
               {"triangles", r.mesh.mesh.triangle_count()},
               {"bad_edges", r.mesh.stats.bad_edges},
               {"merged_junctions", r.mesh.stats.merged_junctions},
               {"fold_repair",
                {{"pairs_found", r.mesh.stats.fold_pairs},
                 {"flips", r.mesh.stats.fold_flips},
                 {"moved_vertices", r.mesh.stats.fold_moves},
                 {"collapsed_edges", r.mesh.stats.fold_collapses},
                 {"refilled_disks", r.mesh.stats.fold_refills}}},
               {"repair",
                {{"pairs_counted", r.repair.counted},
                 {"pairs_found", r.repair.pairs_found},
                 {"pairs_left", r.repair.pairs_left},
                 {"fold_pairs", r.repair.fold_pairs},
                 {"fold_changes", r.repair.fold_changes},
                 {"rounds", r.repair.rounds},
                 {"cut_triangles", r.repair.cut_triangles},
                 {"dropped_triangles", r.repair.dropped_triangles},
                 {"new_vertices", r.repair.new_vertices},
                 {"split_vertices", r.repair.split_vertices},
                 {"inner_shells", r.repair.inner_shells},
                 {"lumps", r.repair.lumps},
                 {"coincident_vertices", r.repair.coincident_vertices},
                 {"problem", r.repair.problem},
                 {"seconds", r.repair.timings.total()}}},
               {"fork_retry",
                {{"pairs_counted", r.fork_retry.counted},
                 {"pairs_counted_everywhere", r.mesh.crossings_counted && r.mesh.crossings_everywhere},
                 {"pairs_before", r.fork_retry.pairs_before},
                 {"pairs_after", r.fork_retry.pairs_after},
                 {"thick_nodes_outside_before", r.fork_retry.outside_before},
                 {"thick_nodes_outside_after", r.fork_retry.outside_after},
                 {"fork_groups", r.fork_retry.groups},
                 {"runs", r.fork_retry.runs},
                 {"webs_refused", r.fork_retry.webs_refused}}},
               {"near_misses",
                {{"tried", r.near_misses.tried},
                 {"thick_nodes_outside_before", r.near_misses.outside_before},
                 {"thick_nodes_outside_after", r.near_misses.outside_after},
                 {"pushes_kept", r.near_misses.covered},
                 {"pushes_undone", r.near_misses.refused},
                 {"moved_vertices", r.near_misses.moved_vertices}}},
               {"outer_surface",
                {{"tried", r.outer_surface.tried},
                 {"applied", r.outer_surface.applied},
                 {"pairs_before", r.outer_surface.pairs_before},
                 {"pairs_after", r.outer_surface.pairs_after},
                 {"thick_nodes_inside_before", r.outer_surface.nodes_inside_before},
                 {"thick_nodes_inside_after", r.outer_surface.nodes_inside_after},
                 {"triangles_before", r.outer_surface.triangles_before},
                 {"triangles_after", r.outer_surface.triangles_after},
                 {"node_spheres", r.outer_surface.blobs},
                 {"clusters", r.outer_surface.clusters},
                 {"clusters_kept", r.outer_surface.clusters_kept},
                 {"refused", r.outer_surface.refused}}},
               {"warnings", std::move(warnings)},
               {"seconds", std::move(seconds)}};
  return j.dump(2) + "\n";
}

void dump_stages(const PipelineResult& r, const std::filesystem::path& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) throw IoError("cannot create directory " + dir.string() + ": " + ec.message());
  const Skeleton& s = r.skeleton.skeleton;
  write_file_atomically(dir / "skeleton.json", skeleton_to_json(s));
  write_file_atomically(dir / "particles.json", particles_to_json(s, r.particles));
  write_file_atomically(dir / "strands.json", strands_to_json(s, r.particles, r.strands));
  write_file_atomically(dir / "contours.json", contours_to_json(r.contours));
  write_file_atomically(dir / "stats.json", stats_to_json(r));
}

}  // namespace sm
