// The repair stage's entry: its steps in order (see repair.h).

#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "meshcheck/checks.h"
#include "repair/repair.h"

namespace sm {
namespace {

/// Warns (`thick_nodes_outside`, naming them) of the thick skeleton nodes the near-miss push
/// left outside the mesh (NearMissStats::left) that are still outside the final mesh (tested
/// again where the outer surface replaced it). Nothing when the push is off, which is where
/// they are found on every mesh size.
void warn_thick_nodes_outside(const Mesh& mesh, const Skeleton& s, const RepairStats& st, Warnings& warnings) {
  std::vector<NodeId> left = st.near_misses.left;
  if (!left.empty() && st.outer_surface.applied) {
    std::vector<glm::dvec3> at;
    for (const NodeId n : left) at.push_back(s.position[n.idx()]);
    const std::vector<std::uint8_t> inside = inside_closed_mesh(mesh, at);
    std::vector<NodeId> still;
    for (std::size_t k = 0; k < left.size(); ++k) {
      if (!inside[k]) still.push_back(left[k]);
    }
    left = std::move(still);
  }
  for (const NodeId n : left) {
    warnings.add("thick_nodes_outside",
                 "skeleton node at least the median radius thick left outside the mesh (after the fork retry, the "
                 "near-miss push and the outer surface)",
                 s.describe(n));
  }
}

}  // namespace

void finish_normals(Mesh& mesh, const RepairParams& params, RepairStats* stats) {
  mesh.corner_normals.clear();
  if (mesh.normals.empty()) return;
  const VertexCorners corners = vertex_corners(mesh);
  mesh.normals = angle_weighted_normals(mesh, corners);
  if (!params.split_normals) return;
  SplitNormals split = split_vertex_normals(mesh, corners, mesh.normals, params.crease_angle);
  mesh.corner_normals = std::move(split.corner_normals);
  if (stats) {
    stats->split_normal_vertices = split.split_vertices;
    stats->extra_normals = split.extra_normals;
  }
}

RepairStats repair_mesh(StitchedMesh stitched, ContourSet& contours, MeshResult& mesh, const RepairInputs& in,
                        const RepairParams& params, const ProgressFn& progress) {
  validate_params(params);
  const Skeleton& s = in.skeleton;
  auto report = [&](std::string_view phase) {
    if (progress) progress(phase, 0);
  };
  Stopwatch clock;
  Timings timings;
  // 1. Folds near the forks, on the stitched numbering; then the surface is finished.
  ForkRetryState state;
  state.folds = repair_junction_folds(stitched, s, contours, params, state.crossings, state.warnings);
  timings.add("junction_folds", clock.lap());
  state.mesh = finish_mesh(std::move(stitched), in.mesh_params);
  timings.add("finish", clock.lap());
  // 2. The fork retry: the mesh kept and its contours, folds and pairs may be a retry's.
  state.contours = std::move(contours);
  const ForkRetryStats fork_retry = retry_forks(state, in, params, progress);
  contours = std::move(state.contours);
  mesh = std::move(state.mesh);
  timings.add("fork_retry", clock.lap());
  // 3. Near misses (they add no pair: the pairs counted still hold).
  NearMissStats near_misses;
  if (params.cover_near_misses) near_misses = cover_near_misses(mesh, s);
  timings.add("near_misses", clock.lap());
  // 4. The outer surface, told of thick nodes outside where the retry left some that the
  // push did not cover.
  report("outer surface");
  const bool nodes_outside =
      fork_retry.outside_after > 0 && (!near_misses.tried || near_misses.outside_after > 0);
  OuterSurfaceStats outer;
  if (params.outer_surface) outer = keep_outer_surface(mesh, state.crossings, s, nodes_outside);
  timings.add("outer_surface", clock.lap());
  // 5. Crossings anywhere: folds and the self-union.
  report("repair");
  RepairStats st = repair_crossings(mesh, s, params, in.input);
  (void)clock.lap();  // (step 5 timed its own parts, in st.timings)
  // The nodes inside stay inside, the input's (`check` counts them all) and the sanitized
  // skeleton's (the repair's rule): a collar's or a sliver's edit is far smaller than what a
  // node, thick or thin, needs to be outside.
  std::vector<glm::dvec3> keep;
  if (params.sliver_angle > 0 || params.collars) {
    keep = s.position;
    if (in.input) keep.insert(keep.end(), in.input->position.begin(), in.input->position.end());
  }
  // 6b. Collars where laterals leave their parents.
  if (params.collars) {
    report("collars");
    st.collars = make_collars(mesh, s,
                              {.reach = params.collar_reach,
                               .edge = params.collar_edge,
                               .blend = params.collar_blend,
                               .max_move = params.collar_max_move,
                               .max_region_triangles = params.collar_max_triangles,
                               .min_angle = params.collar_min_angle,
                               .measure = in.input,
                               .keep_inside = keep},
                              &st.left_pairs);
  }
  timings.add("collars", clock.lap());
  // 7. Slivers.
  std::vector<double> error, radius;
  if (params.sliver_angle > 0) {
    error = cone_error(mesh.mesh, s);
    radius = cone_radius(mesh.mesh, s);
  }
  st.slivers = remove_slivers(mesh, {.angle = params.sliver_angle,
                                     .max_turn = params.sliver_max_turn,
                                     .known_pairs = st.left_pairs ? &*st.left_pairs : nullptr,
                                     .vertex_error = error,
                                     .vertex_radius = radius,
                                     .max_move = params.sliver_max_move,
                                     .keep_inside = keep});
  if (st.slivers.collapses > 0) {
    drop_degenerate(mesh);
    mesh.stats.vertices = mesh.mesh.vertex_count();
    mesh.stats.triangles = mesh.mesh.triangle_count();
  }
  timings.add("slivers", clock.lap());
  // 8. The normals of the finished surface (the steps before moved vertices).
  finish_normals(mesh.mesh, params, &st);
  timings.add("normals", clock.lap());
  st.junction_folds = state.folds;
  st.fork_retry = fork_retry;
  st.near_misses = std::move(near_misses);
  st.outer_surface = std::move(outer);
  for (const auto& e : st.timings.entries) timings.add(e.name, e.seconds);
  st.timings = std::move(timings);
  Warnings warnings = std::move(state.warnings);
  warnings.merge(st.warnings);
  // The pairs left are named by crotch where step 5 did not count them itself (a mesh over
  // count_pairs_up_to: those step 1 left near the forks).
  if (!st.counted) warn_self_intersections_left(state.crossings, s, warnings);
  warn_thick_nodes_outside(mesh.mesh, s, st, warnings);
  st.warnings = std::move(warnings);
  return st;
}

}  // namespace sm
