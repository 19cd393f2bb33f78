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
  // The meshing stage stitches the surface; the repair stage repairs and finishes it (and
  // may re-slice forks: the contours become those of the mesh kept).
  StitchedMesh stitched;
  timed(Stage::meshing, [&] { stitched = stitch_mesh(r.skeleton.skeleton, r.contours, p.meshing, progress); });
  clock.lap();
  const Skeleton input = input_skeleton(raw, p.skeleton);  // (what `check --skeleton` measures against)
  const RepairInputs inputs{r.skeleton.skeleton, r.particles, r.strands, p.contours, p.meshing, &input};
  r.repair = repair_mesh(std::move(stitched), r.contours, r.mesh, inputs, p.repair, progress);
  for (auto& e : r.timings.entries) {
    if (e.name == "repair") e.seconds = 0;
  }
  r.timings.add("repair", clock.lap());
}

PipelineResult run_pipeline(const RawSkeleton& raw, const PipelineParams& params, const ProgressFn& progress) {
  PipelineResult r;
  rerun_pipeline(r, raw, params, Stage::skeleton, progress);
  return r;
}

std::string stats_to_json(const PipelineResult& r, double export_seconds, double total_seconds) {
  using nlohmann::json;
  json seconds;
  for (const char* s : {"skeleton", "particles", "strands", "contours", "meshing", "repair"}) seconds[s] = r.timings.get(s);
  seconds["export"] = export_seconds;
  seconds["total"] = total_seconds > 0 ? total_seconds : r.timings.total() + export_seconds;
  json warnings = json::array();
  const Warnings all = r.warnings();
  for (const auto& w : all.list()) {
    warnings.push_back({{"kind", w.kind}, {"message", w.message}, {"count", w.count}, {"examples", w.examples}});
  }
  const ForkRetryStats& fr = r.repair.fork_retry;
  const NearMissStats& nm = r.repair.near_misses;
  const OuterSurfaceStats& os = r.repair.outer_surface;
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
                {{"pairs_found", r.repair.junction_folds.found},
                 {"flips", r.repair.junction_folds.flips},
                 {"moved_vertices", r.repair.junction_folds.moves},
                 {"collapsed_edges", r.repair.junction_folds.collapses},
                 {"refilled_disks", r.repair.junction_folds.refills}}},
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
                 {"patch_clusters", r.repair.patch_clusters},
                 {"patched", r.repair.patched},
                 {"patch_voxels", r.repair.patch_voxels},
                 {"problem", r.repair.problem},
                 {"seconds", r.repair.timings.total()}}},
               {"collars",
                {{"laterals", r.repair.collars.laterals},
                 {"regions", r.repair.collars.regions},
                 {"made", r.repair.collars.made},
                 {"skipped_pairs", r.repair.collars.skipped_pairs},
                 {"skipped_shape", r.repair.collars.skipped_shape},
                 {"refused_move", r.repair.collars.refused_move},
                 {"refused_pairs", r.repair.collars.refused_pairs},
                 {"refused_inside", r.repair.collars.refused_inside},
                 {"triangles_before", r.repair.collars.triangles_before},
                 {"triangles_after", r.repair.collars.triangles_after}}},
               {"slivers",
                {{"found", r.repair.slivers.found},
                 {"flips", r.repair.slivers.flips},
                 {"collapses", r.repair.slivers.collapses},
                 {"undone", r.repair.slivers.undone},
                 {"kept_out", r.repair.slivers.kept_out},
                 {"left", r.repair.slivers.left}}},
               {"normals",
                {{"split_vertices", r.repair.split_normal_vertices},
                 {"extra_normals", r.repair.extra_normals}}},
               {"fork_retry",
                {{"pairs_counted", fr.counted},
                 {"pairs_counted_everywhere", fr.counted_everywhere},
                 {"pairs_before", fr.pairs_before},
                 {"pairs_after", fr.pairs_after},
                 {"thick_nodes_outside_before", fr.outside_before},
                 {"thick_nodes_outside_after", fr.outside_after},
                 {"fork_groups", fr.groups},
                 {"runs", fr.runs},
                 {"webs_refused", fr.webs_refused}}},
               {"near_misses",
                {{"tried", nm.tried},
                 {"thick_nodes_outside_before", nm.outside_before},
                 {"thick_nodes_outside_after", nm.outside_after},
                 {"pushes_kept", nm.covered},
                 {"pushes_undone", nm.refused},
                 {"moved_vertices", nm.moved_vertices}}},
               {"outer_surface",
                {{"tried", os.tried},
                 {"applied", os.applied},
                 {"pairs_before", os.pairs_before},
                 {"pairs_after", os.pairs_after},
                 {"thick_nodes_inside_before", os.nodes_inside_before},
                 {"thick_nodes_inside_after", os.nodes_inside_after},
                 {"triangles_before", os.triangles_before},
                 {"triangles_after", os.triangles_after},
                 {"node_spheres", os.blobs},
                 {"clusters", os.clusters},
                 {"clusters_kept", os.clusters_kept},
                 {"refused", os.refused}}},
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
