// Step 1 of the repair stage: folds near the forks (see junction_folds.h).

#include "repair/junction_folds.h"

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "meshcheck/intersections.h"
#include "repair/fold_repair.h"
#include "repair/repair.h"

namespace sm {

Crossing crossing_of(const Mesh& mesh, std::uint32_t f, std::uint32_t g) {
  Crossing c;
  for (std::size_t k = 0; k < 6; ++k) {
    const std::uint32_t v = mesh.triangles[k < 3 ? f : g][k % 3];
    c.at += mesh.positions[v] / 6.0;
    if (v < mesh.vertex_node.size()) c.nodes[k] = mesh.vertex_node[v];
  }
  return c;
}

// Runs before finish_mesh drops the unused vertices, while vertex indices are still those of
// the contours (and of the caps after them); the triangles it removes stay as (u, u, u) for
// finish_mesh to drop.
JunctionFoldStats repair_junction_folds(StitchedMesh& stitched, const Skeleton& s, const ContourSet& c,
                                        const RepairParams& params, Crossings& crossings, Warnings& warnings) {
  JunctionFoldStats stats;
  if (params.junction_fold_rounds == 0) return stats;
  Mesh& mesh = stitched.mesh;
  const std::vector<TriangleKind>& kinds = stitched.triangle_kind;
  const double grid = stitched.grid;
  // (Per loop, triangle and vertex in parallel: each writes only its own entries.)
  std::vector<std::uint8_t> near_fork(c.point.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, c.loop_count(), 4096),
                    [&](const tbb::blocked_range<std::uint32_t>& r) {
                      for (std::uint32_t l = r.begin(); l != r.end(); ++l) {
                        if (c.loop_kind[l] != LoopKind::fused && c.loop_kind[l] != LoopKind::split) continue;
                        for (std::uint32_t v = c.loop_begin[l]; v < c.loop_begin[l + 1]; ++v) near_fork[v] = 1;
                      }
                    });
  std::vector<std::uint8_t> suspect(mesh.triangles.size(), 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, suspect.size(), 1 << 14),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t f = r.begin(); f != r.end(); ++f) {
                        if (kinds[f] == TriangleKind::fusion) {
                          suspect[f] = 1;
                        } else if (kinds[f] == TriangleKind::strip) {
                          for (const std::uint32_t v : mesh.triangles[f]) {
                            if (v < near_fork.size() && near_fork[v]) suspect[f] = 1;
                          }
                        }
                      }
                    });
  std::vector<double> max_move(mesh.positions.size(), 0.0);
  const double max_move_factor = std::max(0.0, params.junction_fold_max_move);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, max_move.size(), 1 << 14),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t v = r.begin(); v != r.end(); ++v) {
                        const NodeId n = mesh.vertex_node[v];
                        if (n.valid()) max_move[v] = max_move_factor * s.radius[n.idx()];
                      }
                    });
  FoldRepairOptions options;
  options.max_rounds = static_cast<int>(std::min(params.junction_fold_rounds, 1000u));
  options.collapse = params.junction_fold_collapses;
  options.refill = params.junction_fold_refills;
  options.keep_side = s.position;
  options.grid = grid;
  // Which pairs a repair untangles depends on the order of its attempts. On meshes of at most
  // count_pairs_up_to triangles, the pairs left anywhere are counted (the repair itself
  // watches only the triangles around its changes), and where there are
  // some, two more variants (vertex moves also towards the branch's axis, after or before the
  // other targets) start again from the stitched mesh; the run leaving the fewest is kept.
  // Samples x particle seeds 1-3: 161 -> 135 pairs (the first variant won on agraf seed 2 and
  // boutdenoylum2 seeds 2 and 3, 7 / 9 -> 0, the second on agraf seed 3 and small_pine seeds
  // 1 and 2); their fold repair takes 3-7 times as long (boutdenoylum2 0.3 -> 2.2 s), a count
  // 0.03-0.13 s. Clean meshes pay one count; larger meshes (the grown presets, the bench tree)
  // nothing. (Off by default: RepairParams::junction_fold_variants. The count is made for the
  // later steps as well, which start from the pairs left: Crossings.)
  // (The undo log is kept only where variants may follow: it costs a hash insert per change.)
  const bool small =
      mesh.triangles.size() <= params.count_pairs_up_to && mesh.vertex_node.size() == mesh.positions.size();
  const bool variants = params.junction_fold_variants && small;
  FoldRepairUndo undo;
  FoldRepairStats r = sm::repair_folds(mesh, suspect, max_move, options, variants ? &undo : nullptr);
  // The pairs left anywhere, with where they are and the skeleton nodes of their corners (the
  // fork retry places them by these).
  std::vector<Crossing> at;
  auto pairs_left = [&] {
    std::vector<std::uint32_t> all(mesh.triangles.size());
    std::iota(all.begin(), all.end(), 0u);
    std::vector<Crossing> out;
    for (const auto& [f, g] : TriangleIntersections(mesh).pairs(all)) out.push_back(crossing_of(mesh, f, g));
    return out;
  };
  const bool repair_stopped = r.gave_up || r.out_of_tests;
  const bool counted = (variants || (params.fork_retry && small)) && !repair_stopped;
  if (counted) {
    at = pairs_left();
    crossings.counted = true;
  } else if (!small && (params.fork_retry || params.outer_surface) && !repair_stopped) {
    // Larger meshes: the pairs the repair left among the triangles it examined (a count over
    // the whole mesh would cost more than the repair: 0.3 s on 800,000 triangles).
    for (const auto& [f, g] : r.left) at.push_back(crossing_of(mesh, f, g));
    crossings.counted = true;
    crossings.everywhere = false;
  }
  if (variants && !at.empty()) {
    std::vector<glm::dvec3> axis(mesh.positions.size());
    for (std::size_t v = 0; v < axis.size(); ++v) {
      const NodeId n = mesh.vertex_node[v];
      const glm::dvec3& p = mesh.positions[v];
      const NodeId par = n.valid() ? s.parent[n.idx()] : NodeId{};
      if (!par.valid()) {
        axis[v] = n.valid() ? s.position[n.idx()] : p;
        continue;
      }
      const glm::dvec3 a = s.position[par.idx()], b = s.position[n.idx()];
      axis[v] = a + segment_param(p, a, b) * (b - a);
    }
    // `undo` holds the stitched values while the mesh holds the best run's (applied), and the
    // best run's values while the mesh is back to the stitched one.
    bool applied = true;
    for (const AxisTargets variant : {AxisTargets::last, AxisTargets::first}) {
      if (applied) undo.swap_with(mesh);
      FoldRepairOptions o = options;
      o.axis_point = axis;
      o.axis_targets = variant;
      FoldRepairUndo u;
      const FoldRepairStats rv = sm::repair_folds(mesh, suspect, max_move, o, &u);
      const bool stopped = rv.gave_up || rv.out_of_tests;
      std::vector<Crossing> at_v = stopped ? std::vector<Crossing>{} : pairs_left();
      applied = !stopped && at_v.size() < at.size();
      if (applied) {
        r = rv;
        at = std::move(at_v);
        undo = std::move(u);
      } else {
        u.swap_with(mesh);  // back to the stitched mesh
      }
    }
    if (!applied) undo.swap_with(mesh);
  }
  crossings.pairs = std::move(at);
  stats.found = r.found;
  stats.flips = r.flips;
  stats.moves = r.moves;
  stats.collapses = r.collapses;
  stats.refills = r.refills;
  if (r.out_of_tests) {
    warnings.add("fold_repair_stopped", "fold repair stopped at its budget of triangle tests (" +
                                            std::to_string(options.max_tests_per_triangle) +
                                            " per triangle): branches run through each other; see the "
                                            "skeleton's separation warnings");
  }
  if (r.gave_up) {
    warnings.add_count(
        "fold_repair_skipped",
        "too many self-intersecting triangle pairs near junctions for the fold repair (more than " +
            std::to_string(options.max_pairs) +
            "): branches run through each other; see the skeleton's separation warnings",
        r.found);
  }
  return stats;
}

}  // namespace sm
