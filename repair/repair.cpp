// Repair stage (see repair.h).

#include "repair/repair.h"

#include <algorithm>
#include <numeric>
#include <optional>
#include <set>
#include <span>
#include <tuple>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/errors.h"
#include "core/union_find.h"
#include "meshcheck/checks.h"
#include "meshcheck/intersections.h"
#include "repair/fold_repair.h"
#include "repair/self_union.h"
#include "repair/volume_patch.h"
#include "repair/verdict.h"

namespace sm {
namespace {
constexpr std::uint32_t kNoTriangle = UINT32_MAX;
}  // namespace


std::vector<std::uint32_t> drop_degenerate(MeshResult& r) {
  Mesh& m = r.mesh;
  const bool kinds = r.triangle_kind.size() == m.triangles.size(), uvs = m.corner_uvs.size() == m.triangles.size(),
             branches = m.triangle_branch.size() == m.triangles.size();
  std::size_t w = 0;
  std::vector<std::uint32_t> origin;
  origin.reserve(m.triangles.size());
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    const auto& t = m.triangles[f];
    if (t[0] == t[1] && t[1] == t[2]) continue;
    origin.push_back(static_cast<std::uint32_t>(f));
    m.triangles[w] = t;
    if (kinds) r.triangle_kind[w] = r.triangle_kind[f];
    if (uvs) m.corner_uvs[w] = m.corner_uvs[f];
    if (branches) m.triangle_branch[w] = m.triangle_branch[f];
    ++w;
  }
  m.triangles.resize(w);
  if (kinds) r.triangle_kind.resize(w);
  if (uvs) m.corner_uvs.resize(w);
  if (branches) m.triangle_branch.resize(w);
  const std::size_t nv = m.positions.size();
  std::vector<std::uint32_t> renumber(nv, UINT32_MAX);
  for (const auto& t : m.triangles) {
    for (const std::uint32_t v : t) renumber[v] = 0;
  }
  std::uint32_t used = 0;
  const bool nodes = m.vertex_node.size() == nv, strands = m.vertex_strand.size() == nv, normals = m.normals.size() == nv;
  for (std::size_t v = 0; v < nv; ++v) {
    if (renumber[v] == UINT32_MAX) continue;
    renumber[v] = used;
    m.positions[used] = m.positions[v];
    if (nodes) m.vertex_node[used] = m.vertex_node[v];
    if (strands) m.vertex_strand[used] = m.vertex_strand[v];
    if (normals) m.normals[used] = m.normals[v];
    ++used;
  }
  m.positions.resize(used);
  if (nodes) m.vertex_node.resize(used);
  if (strands) m.vertex_strand.resize(used);
  if (normals) m.normals.resize(used);
  for (auto& t : m.triangles) {
    for (auto& v : t) v = renumber[v];
  }
  return origin;
}

namespace {

/// Connected parts of the mesh (through shared vertices).
std::size_t components(const Mesh& m) {
  UnionFind parts(m.positions.size());
  std::vector<std::uint8_t> used(m.positions.size(), 0);
  for (const auto& t : m.triangles) {
    parts.unite(t[0], t[1]);
    parts.unite(t[1], t[2]);
    used[t[0]] = used[t[1]] = used[t[2]] = 1;
  }
  std::size_t n = 0;
  for (std::uint32_t v = 0; v < used.size(); ++v) n += used[v] && parts.find(v) == v;
  return n;
}

/// Per triangle of an edited mesh, the kind of the triangle it came from (`origin`: its index
/// before the edit); empty where there were no kinds.
std::vector<TriangleKind> kinds_by_origin(const std::vector<TriangleKind>& kinds, const std::vector<std::uint32_t>& origin) {
  if (kinds.empty()) return {};
  std::vector<TriangleKind> out(origin.size());
  for (std::size_t f = 0; f < origin.size(); ++f) out[f] = kinds[origin[f]];
  return out;
}

/// Vertices at the same position as another (a collapse or a cut line ending on a vertex can
/// leave two): readers weld them, pinching the surface there. Every one but the first of each
/// position moves two grid steps (or 1 % of the way, if longer) towards the centroid of its
/// neighbours, on the grid. Returns how many moved.
std::size_t separate_coincident(Mesh& mesh, double grid) {
  std::vector<std::uint32_t> order;
  std::vector<std::uint8_t> used(mesh.positions.size(), 0);
  for (const auto& t : mesh.triangles) used[t[0]] = used[t[1]] = used[t[2]] = 1;
  for (std::uint32_t v = 0; v < used.size(); ++v) {
    if (used[v]) order.push_back(v);
  }
  const auto key = [&](std::uint32_t v) {
    const glm::dvec3& p = mesh.positions[v];
    return std::tuple(p.x, p.y, p.z, v);
  };
  std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return key(a) < key(b); });
  std::vector<std::uint32_t> moving;
  for (std::size_t k = 1; k < order.size(); ++k) {
    if (mesh.positions[order[k]] == mesh.positions[order[k - 1]]) moving.push_back(order[k]);
  }
  if (moving.empty()) return 0;
  std::vector<glm::dvec3> sum(mesh.positions.size(), glm::dvec3(0.0));
  std::vector<double> count(mesh.positions.size(), 0.0);
  for (const auto& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      sum[t[k]] += mesh.positions[t[(k + 1) % 3]] + mesh.positions[t[(k + 2) % 3]];
      count[t[k]] += 2;
    }
  }
  for (const std::uint32_t v : moving) {
    mesh.positions[v] = step_towards(mesh.positions[v], sum[v] / count[v], grid);
  }
  return moving.size();
}

/// The input's nodes of `skeleton` (source_id >= 0), each joined to its nearest input ancestor:
/// the round cones the volume patch draws, and what its fidelity is measured against (only
/// position, radius, parent and source_id filled, as input_skeleton). The skeleton itself where
/// it has no source ids. `index` receives, per node of the result, its index in `skeleton`.
Skeleton input_nodes(const Skeleton& skeleton, std::vector<std::uint32_t>& index) {
  index.resize(skeleton.size());
  std::iota(index.begin(), index.end(), 0u);
  if (skeleton.source_id.size() != skeleton.size()) return skeleton;
  index.clear();
  Skeleton out;
  out.up_axis = skeleton.up_axis;
  std::vector<NodeId> now(skeleton.size());  // nearest input node at or above each node
  for (std::size_t i = 0; i < skeleton.size(); ++i) {
    const NodeId up = skeleton.parent[i].valid() ? now[skeleton.parent[i].idx()] : NodeId{};
    if (skeleton.source_id[i] < 0 && (up.valid() || i > 0)) {
      now[i] = up;
      continue;
    }
    now[i] = NodeId(static_cast<std::uint32_t>(out.size()));
    index.push_back(static_cast<std::uint32_t>(i));
    out.position.push_back(skeleton.position[i]);
    out.radius.push_back(skeleton.radius[i]);
    out.parent.push_back(up);
    out.source_id.push_back(skeleton.source_id[i]);
  }
  out.children.resize(out.size());
  out.frame.resize(out.size());
  return out;
}

/// How many of `points` lie inside the closed mesh `m`.
std::size_t count_inside(const Mesh& m, std::span<const glm::dvec3> points) {
  const std::vector<std::uint8_t> in = inside_closed_mesh(m, points);
  return static_cast<std::size_t>(std::count(in.begin(), in.end(), std::uint8_t{1}));
}

/// How many of `pairs` have a triangle whose centroid lies in the box {lo, hi}.
std::size_t pairs_in_box(const Mesh& mesh, const std::vector<std::array<std::uint32_t, 2>>& pairs,
                         const std::array<glm::dvec3, 2>& box) {
  auto in_box = [&](std::uint32_t f) {
    const auto& t = mesh.triangles[f];
    const glm::dvec3 c = (mesh.positions[t[0]] + mesh.positions[t[1]] + mesh.positions[t[2]]) / 3.0;
    return glm::all(glm::greaterThanEqual(c, box[0])) && glm::all(glm::lessThanEqual(c, box[1]));
  };
  return static_cast<std::size_t>(
      std::count_if(pairs.begin(), pairs.end(), [&](const auto& pr) { return in_box(pr[0]) || in_box(pr[1]); }));
}

/// The self-intersecting pairs of `after`, an edit of `before` whose pairs were `pairs`;
/// `origin[g]` names the triangle of `before` that triangle g of `after` may still be (or
/// kNoTriangle). Pairs of triangles both found unchanged (the same three positions in the same
/// turn as their origin, each origin claimed once, by the first) carry over, and the rest are
/// looked for around the changed triangles only (the repair's edits are local). The edits
/// report their origins (the fold repair keeps triangle indices, the self-union hands them
/// on): no triangle of the whole mesh is hashed. `known` (where given): triangles of `after`
/// (increasing) whose pairs the edit already found, all of them (`known_pairs`, sorted).
struct KnownPairs {
  const std::vector<std::uint32_t>& triangles;
  const std::vector<std::array<std::uint32_t, 2>>& pairs;
};
std::vector<std::array<std::uint32_t, 2>> pairs_after_edit(const Mesh& before,
                                                           const std::vector<std::array<std::uint32_t, 2>>& pairs,
                                                           const Mesh& after, const std::vector<std::uint32_t>& origin,
                                                           std::vector<std::array<std::uint32_t, 2>>* fresh = nullptr,
                                                           std::optional<KnownPairs> known = std::nullopt) {
  const auto nf = static_cast<std::uint32_t>(after.triangles.size());
  // Whether g's positions are o's, turned or not.
  auto same = [&](std::uint32_t g, std::uint32_t o) {
    const auto &t = after.triangles[g], &u = before.triangles[o];
    const glm::dvec3 p[3] = {after.positions[t[0]], after.positions[t[1]], after.positions[t[2]]};
    const glm::dvec3 q[3] = {before.positions[u[0]], before.positions[u[1]], before.positions[u[2]]};
    for (int r = 0; r < 3; ++r) {
      if (p[0] == q[r] && p[1] == q[(r + 1) % 3] && p[2] == q[(r + 2) % 3]) return true;
    }
    return false;
  };
  std::vector<std::uint8_t> kept(nf, 0);
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, nf, 1 << 14), [&](const tbb::blocked_range<std::uint32_t>& r) {
    for (std::uint32_t g = r.begin(); g != r.end(); ++g) {
      const std::uint32_t o = origin[g];
      kept[g] = o != kNoTriangle && same(g, o);
    }
  });
  std::vector<std::uint32_t> now(before.triangles.size(), kNoTriangle);  // before -> after, unchanged ones
  std::vector<std::uint32_t> changed;
  std::size_t k = 0;  // (the next of the known triangles)
  for (std::uint32_t g = 0; g < nf; ++g) {
    if (kept[g] && now[origin[g]] == kNoTriangle) {
      now[origin[g]] = g;
      continue;
    }
    while (known && k < known->triangles.size() && known->triangles[k] < g) ++k;
    if (!known || k == known->triangles.size() || known->triangles[k] != g) changed.push_back(g);
  }
  std::vector<std::array<std::uint32_t, 2>> out = TriangleIntersections(after).pairs_touching(changed);
  if (known) {
    // (Every pair touching a changed triangle: those touching the known ones, and the rest.)
    out.insert(out.end(), known->pairs.begin(), known->pairs.end());
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }
  if (fresh) *fresh = out;
  for (const auto& [f, g] : pairs) {
    if (now[f] != kNoTriangle && now[g] != kNoTriangle) out.push_back({std::min(now[f], now[g]), std::max(now[f], now[g])});
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace

void validate_params(const RepairParams& p) { check_params(p); }

RepairStats repair_crossings(MeshResult& r, const Skeleton& skeleton, const RepairParams& params,
                             const Skeleton* input_skeleton) {
  validate_params(params);
  RepairStats st;
  Stopwatch clock;
  Mesh& mesh = r.mesh;
  auto all_pairs = [&] {
    std::vector<std::uint32_t> all(mesh.triangles.size());
    std::iota(all.begin(), all.end(), 0u);
    return TriangleIntersections(mesh).pairs(all);
  };
  if (mesh.triangles.size() > params.count_pairs_up_to) return st;
  st.counted = true;
  std::vector<std::array<std::uint32_t, 2>> pairs = all_pairs();
  st.pairs_found = pairs.size();

  st.timings.add("find_pairs", clock.lap());
  // Folds first: pairs of triangles within two rings of each other are creases of one sheet
  // (a tight crotch, a zigzag), which flips, moves and collapses untangle in place; a cut line
  // of the union would end inside them.
  // `crossing`: the mesh's pairs, renumbered after the repair; `seeds` (where given): the pairs
  // whose folds it starts from, e.g. those an edit made (the others were tried before).
  auto untangle_folds = [&](std::vector<std::array<std::uint32_t, 2>>& crossing,
                            const std::vector<std::array<std::uint32_t, 2>>* seeds = nullptr) {
    if (params.fold_rounds == 0 || crossing.empty()) return;
    const VertexCorners vc = vertex_corners(mesh);
    std::vector<std::uint8_t> suspect(mesh.triangles.size(), 0);
    std::vector<std::uint32_t> near;
    auto ring = [&](std::uint32_t f, std::vector<std::uint32_t>& out) {
      for (const std::uint32_t v : mesh.triangles[f]) {
        for (std::uint32_t k = vc.begin[v]; k < vc.begin[v + 1]; ++k) out.push_back(vc.corner[k] / 3);
      }
    };
    std::size_t folds = 0;
    for (const auto& [f, g] : seeds ? *seeds : crossing) {
      near.clear();
      ring(f, near);
      const std::size_t first = near.size();
      for (std::size_t k = 0; k < first; ++k) ring(near[k], near);
      if (std::find(near.begin(), near.end(), g) == near.end()) continue;
      ++folds;
      suspect[f] = suspect[g] = 1;
    }
    if (folds > 0) {
      std::vector<double> max_move(mesh.positions.size(), 0.0);
      for (std::size_t v = 0; v < max_move.size() && mesh.vertex_node.size() == max_move.size(); ++v) {
        const NodeId n = mesh.vertex_node[v];
        if (n.valid()) max_move[v] = params.fold_max_move * skeleton.radius[n.idx()];
      }
      FoldRepairOptions options;
      options.max_rounds = static_cast<int>(params.fold_rounds);
      options.keep_side = skeleton.position;
      options.grid = r.grid;
      // Folds are local: a large tree has more of them, not worse ones (the test budget,
      // per triangle, bounds the cost).
      options.max_pairs = std::max(options.max_pairs, mesh.triangles.size() / 8);
      MeshResult before = r;
      const FoldRepairStats fr = repair_folds(mesh, suspect, max_move, options);
      st.fold_pairs += folds;
      const std::size_t changes = fr.flips + fr.moves + fr.collapses + fr.refills;
      st.fold_changes += changes;
      const std::vector<std::uint32_t> kept = drop_degenerate(r);
      // Kept only as a closed 2-manifold (its collapses and refills can pinch an edge).
      if (const std::size_t open = unpaired_half_edges(mesh, vertex_corners(mesh)); open > 0) {
        st.problem = "the fold repair left " + std::to_string(open) + " unpaired half-edges (undone)";
        st.fold_changes -= changes;
        r = std::move(before);
      } else {
        crossing = pairs_after_edit(before.mesh, crossing, mesh, kept);
      }
      st.timings.add("folds", clock.lap());
    }
  };
  untangle_folds(pairs);
  std::vector<std::uint32_t> origin;
  // Pairs a round left out (their union could not be judged) are not tried again: the rounds
  // after it meet only the pairs it made.
  std::set<std::array<std::uint32_t, 2>> left_out;
  auto ordered = [](std::uint32_t a, std::uint32_t b) { return std::array<std::uint32_t, 2>{std::min(a, b), std::max(a, b)}; };
  // A round is kept by the repair's rule (verdict.h; a handle allowed, the thick skeleton
  // nodes inside counted); otherwise the mesh goes back to what it was and the repair stops.
  std::vector<glm::dvec3> thick;
  for (const std::uint32_t i : thick_node_ids(skeleton)) thick.push_back(skeleton.position[i]);
  auto thick_inside = [&](const Mesh& m) { return count_inside(m, thick); };
  MeshFigures now;
  if (params.self_union && !pairs.empty()) {
    now = {.parts = components(mesh), .volume = signed_volume(mesh), .pairs = pairs.size(),
           .thick_inside = thick_inside(mesh)};
  }
  while (params.self_union && !pairs.empty() && st.rounds < params.max_rounds) {
    std::vector<std::array<std::uint32_t, 2>> to_try;
    for (const auto& [f, g] : pairs) {
      if (!left_out.contains(ordered(f, g))) to_try.push_back({f, g});
    }
    if (to_try.empty()) break;
    ++st.rounds;
    MeshResult before = r;
    const SelfUnionStats u = self_union(mesh, to_try, r.grid, skeleton.position, origin);
    if (!u.problem.empty()) {
      st.problem = u.problem;
      st.timings.add("self_union", clock.lap());  // (its attempts' time too)
      break;
    }
    // The figures after it, measured only as far as the rule reads them (it stops at the first
    // respect in which the mesh does worse). A part turned inside out and kept as it was can
    // turn the whole surface over: the volume.
    std::vector<std::array<std::uint32_t, 2>> after;
    MeshFigures next{.sound = unpaired_half_edges(mesh, vertex_corners(mesh)) == 0, .parts = components(mesh)};
    if (next.sound && next.parts <= now.parts) {
      next.volume = signed_volume(mesh);
      after = pairs_after_edit(before.mesh, pairs, mesh, origin);
      next.pairs = after.size();
      next.thick_inside = thick_inside(mesh);
    }
    st.timings.add("self_union", clock.lap());
    if (const std::string why = refuse(now, next, {.handles_allowed = true}); !why.empty()) {
      st.problem = why;
      r = std::move(before);
      break;
    }
    now = next;
    st.cut_triangles += u.cut_triangles;
    st.dropped_triangles += u.dropped_triangles;
    st.new_vertices += u.new_vertices;
    st.split_vertices += u.split_vertices;
    st.inner_shells += u.inner_shells;
    st.lumps += u.lumps;
    r.triangle_kind = kinds_by_origin(r.triangle_kind, origin);
    // The pairs left out, in the new numbering: their triangles were not cut, so each is the
    // one triangle of the result from its origin.
    std::vector<std::uint32_t> now_of(before.mesh.triangles.size(), kNoTriangle), count(now_of.size(), 0);
    for (std::uint32_t f = 0; f < origin.size(); ++f) {
      now_of[origin[f]] = f;
      ++count[origin[f]];
    }
    std::set<std::array<std::uint32_t, 2>> still;
    auto carry = [&](std::uint32_t a, std::uint32_t b) {
      if (count[a] == 1 && count[b] == 1) still.insert(ordered(now_of[a], now_of[b]));
    };
    for (const auto& [a, b] : left_out) carry(a, b);
    for (const auto& [a, b] : u.left_out_pairs) carry(a, b);
    left_out = std::move(still);
    pairs = std::move(after);
  }
  // Step 6: what the union left, patched from a voxel grid of the solid around it; then, in a
  // second pass kept only where it does better again (so that it cannot cost the first pass's
  // patches), the thick nodes still outside (a hub or a hairpin the slicing could not
  // separate) with the pairs left, whose regions merge with theirs where they overlap.
  const bool can_patch = params.volume_patch && mesh.vertex_node.size() == mesh.positions.size();
  std::vector<std::uint32_t> input_index;
  const Skeleton input = can_patch ? input_nodes(skeleton, input_index) : Skeleton{};
  // Input nodes inside (all of them, not only the thick ones).
  auto nodes_inside = [&](const Mesh& m) { return count_inside(m, input.position); };
  auto patch_pass = [&](const std::vector<std::array<std::uint32_t, 2>>& patch_pairs,
                        const std::vector<std::uint32_t>& uncovered, const char* warning, const char* what,
                        std::optional<std::size_t> all_inside = std::nullopt, bool last = false) {
    // (Given: the pass for thin nodes, judged by all input nodes inside, counted by the caller.)
    const bool count_all = all_inside.has_value();
    if (patch_pairs.empty() && uncovered.empty()) return;
    if (!params.self_union || now.pairs != pairs.size() || !now.thick_inside) {
      now = {.parts = components(mesh), .volume = signed_volume(mesh), .pairs = pairs.size(),
             .thick_inside = thick_inside(mesh)};
    }
    now.nodes_inside = all_inside;
    // The second pass is also held to the fidelity to the input's cones (its patches' many
    // vertices on twigs drawn thicker than they are can cost more than the nodes they bring
    // inside are worth).
    auto fidelity = [&] { return fidelity_p95(mesh, input_skeleton ? *input_skeleton : input); };
    if (!uncovered.empty() || last) {
      now.fidelity_p95 = fidelity();
      // A margin under the check's tolerance: a tenth against the file's skeleton (what the
      // check measures), two thirds against the sanitized one, which lacks the input nodes the
      // sanitizing merged (against which messy seed 182 came out at 0.1502).
      now.fidelity_tolerance = MeshCheckParams{}.fidelity_tolerance * (input_skeleton ? 0.9 : 2.0 / 3);
      // Thin nodes are worth less: two thirds (a node of messy seed 228 took p95 0.066 -> 0.123).
      if (count_all) now.fidelity_tolerance = MeshCheckParams{}.fidelity_tolerance * 2.0 / 3;
    }
    VolumePatchOptions options;
    options.voxels_per_radius = params.patch_voxels_per_radius;
    options.reach = params.patch_reach;
    options.max_voxels = params.patch_max_voxels;
    // (The passes for thin nodes and for the pairs left get a quarter: a twig's node is worth
    // less than a crossing, and the pairs left failed once already.)
    options.max_total_voxels = count_all ? params.patch_budget_voxels / 4 : params.patch_budget_voxels;
    options.min_twig_voxels = params.patch_min_twig_voxels;
    options.grid = r.grid;
    options.allow_crossings = true;  // the fold repair below untangles the seams' creases
    options.uncovered = uncovered;
    // Kept by the repair's rule after the untangling; where refused with several patches, once
    // more with a subset of them (below), so that a few bad regions do not cost the others.
    VolumePatchStats vp;
    const std::string problem_before = st.problem;
    // (The last pass is tried once: a subset of regions that failed twice is seldom worth it.)
    for (int attempt = 0; attempt < (last ? 1 : 2); ++attempt) {
      MeshResult before = r;
      vp = volume_patch(mesh, patch_pairs, skeleton, options, origin);
      st.timings.add("volume_patch", clock.lap());
      st.patch_clusters += vp.clusters;
      st.patch_voxels += vp.voxels;
      if (vp.patched == 0) break;
      r.triangle_kind = kinds_by_origin(before.triangle_kind, origin);
      std::vector<std::array<std::uint32_t, 2>> after;
      MeshFigures next{.sound = unpaired_half_edges(mesh, vertex_corners(mesh)) == 0, .parts = components(mesh)};
      if (next.sound && next.parts <= now.parts) {
        std::vector<std::array<std::uint32_t, 2>> made;
        after = pairs_after_edit(before.mesh, pairs, mesh, origin, &made,
                                 KnownPairs{vp.new_triangles_of_result, vp.pairs_of_new});
        // The patches' own creases (where the voxel surface meets the cut one) are folds. In
        // the pass for thin nodes only those are untangled: the pairs the patches did not touch
        // were tried before, and on a large tree trying them again costs more than the pass.
        untangle_folds(after, count_all ? &made : nullptr);
        // Where the seams of a pass that brought nodes inside leave more pairs than there were,
        // one round of patches around those as they are now, before the pass is judged.
        if (count_all && params.patch_left && attempt == 0 && after.size() > now.pairs && now.nodes_inside &&
            nodes_inside(mesh) > *now.nodes_inside) {
          const Mesh mid = mesh;
          std::vector<std::uint32_t> origin2;
          VolumePatchOptions seams = options;
          seams.uncovered.clear();
          seams.leave_out.clear();
          const VolumePatchStats vp2 = volume_patch(mesh, after, skeleton, seams, origin2);
          st.timings.add("volume_patch", clock.lap());
          st.patch_clusters += vp2.clusters;
          st.patch_voxels += vp2.voxels;
          if (vp2.patched > 0) {
            r.triangle_kind = kinds_by_origin(r.triangle_kind, origin2);
            std::vector<std::array<std::uint32_t, 2>> made2;
            after = pairs_after_edit(mid, after, mesh, origin2, &made2,
                                     KnownPairs{vp2.new_triangles_of_result, vp2.pairs_of_new});
            untangle_folds(after, &made2);
          }
        }
        next.sound = unpaired_half_edges(mesh, vertex_corners(mesh)) == 0;
        next.parts = components(mesh);
        next.volume = signed_volume(mesh);
        next.pairs = after.size();
        next.thick_inside = thick_inside(mesh);
        if (count_all) next.nodes_inside = nodes_inside(mesh);
        if (now.fidelity_p95) next.fidelity_p95 = fidelity();
        st.timings.add("patch_figures", clock.lap());
      }
      if (const std::string why = refuse(now, next, {.handles_allowed = true}); !why.empty()) {
        st.problem = "volume patch: " + why;
        if (vp.patched < 2) {
          r = std::move(before);
          break;
        }
        // The regions that hold more pairs after than before are left out; where none does
        // (or the result was not sound), the one whose seams made the most crossings. The
        // regions not made are left out too: the next try is a subset of this one.
        options.leave_out.assign(vp.seam_crossings.size(), 0);
        for (std::size_t k = 0; k < vp.made.size() && k < options.leave_out.size(); ++k) options.leave_out[k] = !vp.made[k];
        bool any = false;
        if (next.sound && vp.regions.size() == vp.seam_crossings.size()) {
          for (std::size_t k = 0; k < vp.seam_crossings.size(); ++k) {
            if (vp.seam_crossings[k] == 0) continue;  // (not patched, or made no crossing)
            if (pairs_in_box(mesh, after, vp.regions[k]) > pairs_in_box(before.mesh, pairs, vp.regions[k]))
              options.leave_out[k] = any = 1;
          }
        }
        if (!any) {
          const auto worst = std::max_element(vp.seam_crossings.begin(), vp.seam_crossings.end()) - vp.seam_crossings.begin();
          options.leave_out[static_cast<std::size_t>(worst)] = 1;
        }
        r = std::move(before);
      } else {
        st.problem = problem_before;
        st.patched += vp.patched;
        now = next;
        pairs = std::move(after);
        break;
      }
    }
    // One warning (warnings merge by kind) that counts each reason.
    std::string reasons;
    std::size_t refused = 0;
    for (const auto& [why, count] : vp.failures) {
      reasons += (reasons.empty() ? "" : "; ") + std::to_string(count) + "x " + why;
      refused += count;
    }
    st.warnings.add_count(warning, std::string(what) + " not patched (" + reasons + ")", refused);
  };
  if (can_patch) patch_pass(pairs, {}, "volume_patch_refused", "region of crossings");
  if (can_patch && params.patch_uncovered) {
    // (Thick by the input's median radius, as `check --skeleton` counts them.)
    std::vector<std::uint32_t> uncovered;
    const std::vector<std::uint32_t> ids = thick_node_ids(input);
    std::vector<glm::dvec3> at;
    for (const std::uint32_t i : ids) at.push_back(input.position[i]);
    const std::vector<std::uint8_t> in = inside_closed_mesh(mesh, at);
    for (std::size_t k = 0; k < ids.size(); ++k) {
      if (!in[k]) uncovered.push_back(input_index[ids[k]]);
    }
    if (!uncovered.empty()) patch_pass(pairs, uncovered, "volume_patch_refused_nodes", "region around a thick node outside");
    // Then every input node still outside (a twig's first node at a hub of webs), each at its
    // own scale, kept only where more nodes are inside and nothing else is worse.
    if (params.patch_uncovered_thin) {
      uncovered.clear();
      const std::vector<std::uint8_t> in_all = inside_closed_mesh(mesh, input.position);
      for (std::size_t k = 0; k < in_all.size(); ++k) {
        if (!in_all[k]) uncovered.push_back(input_index[k]);
      }
      if (!uncovered.empty()) {
        patch_pass(pairs, uncovered, "volume_patch_refused_thin", "region around a node outside",
                   in_all.size() - uncovered.size());
      }
    }
  }
  // Last, the crossings still left, in regions drawn around them as they are now (the passes
  // for nodes and their fold repairs moved the surface, and with it the spots where a region's
  // faces cut two surfaces a voxel apart); kept only where fewer pairs are left and neither the
  // input's nodes inside nor the fidelity to its cones get worse.
  if (can_patch && params.patch_left && !pairs.empty()) {
    patch_pass(pairs, {}, "volume_patch_refused_left", "region of crossings left", nodes_inside(mesh), true);
  }
  st.coincident_vertices = separate_coincident(mesh, r.grid);
  st.pairs_left = pairs.size();
  if (st.counted && (st.coincident_vertices == 0 || pairs.empty())) st.left_pairs = pairs;
  r.stats.vertices = mesh.vertex_count();
  r.stats.triangles = mesh.triangle_count();
  if (!st.problem.empty()) st.warnings.add("self_union_refused", "the self-union was refused: " + st.problem);
  if (st.pairs_left > 0) {
    st.warnings.add_count("self_intersections_left", "self-intersecting triangle pairs left after the repair",
                          st.pairs_left);
  }
  return st;
}

}  // namespace sm
