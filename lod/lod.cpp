// Levels of detail by re-running the pipeline on a pruned skeleton with coarser parameters.

#include "lod/lod.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

#include "core/errors.h"
#include "lod/simplify.h"
#include "meshcheck/intersections.h"

namespace sm {

RawSkeleton prune_thin_branches(const RawSkeleton& raw, double min_radius, std::size_t* pruned) {
  const std::size_t n = raw.size();
  std::unordered_map<std::int64_t, std::size_t> index;
  index.reserve(n);
  for (std::size_t i = 0; i < n; ++i) index.emplace(raw.id[i], i);
  std::vector<std::vector<std::size_t>> children(n);
  std::size_t root = n;
  for (std::size_t i = 0; i < n; ++i) {
    const auto it = index.find(raw.parent_id[i]);
    if (raw.parent_id[i] < 0 || it == index.end()) {
      if (root == n) root = i;
    } else {
      children[it->second].push_back(i);
    }
  }
  if (root == n) throw InvalidInputError(raw.source + ": the skeleton has no root");
  // Keep the root, and from it every node at least min_radius thick whose parent is kept.
  std::vector<std::uint8_t> keep(n, 0);
  keep[root] = 1;
  std::vector<std::size_t> stack{root};
  while (!stack.empty()) {
    const std::size_t i = stack.back();
    stack.pop_back();
    for (const std::size_t c : children[i]) {
      if (raw.radius[c] >= min_radius || (i == root && c == children[root].front())) {
        keep[c] = 1;
        stack.push_back(c);
      }
    }
  }
  RawSkeleton out;
  out.up_axis = raw.up_axis;
  out.source = raw.source;
  out.sanitized = raw.sanitized;
  out.grown = raw.grown;
  std::size_t removed = 0;
  for (std::size_t i = 0; i < n; ++i) {
    if (!keep[i]) {
      ++removed;
      continue;
    }
    out.id.push_back(raw.id[i]);
    out.parent_id.push_back(raw.parent_id[i]);
    out.position.push_back(raw.position[i]);
    out.radius.push_back(raw.radius[i]);
    if (!raw.where.empty()) out.where.push_back(raw.where[i]);
  }
  if (pruned != nullptr) *pruned = removed;
  return out;
}

LodLevel lod_level(const RawSkeleton& raw, const PipelineParams& params, std::uint32_t level, const LodParams& lod) {
  LodLevel l;
  double root_radius = 0;
  for (std::size_t i = 0; i < raw.size(); ++i) {
    if (raw.parent_id[i] < 0) {
      root_radius = raw.radius[i];
      break;
    }
  }
  l.min_radius = lod.prune_radius * std::pow(4.0, double(level) - 1.0) * root_radius;
  l.skeleton = prune_thin_branches(raw, l.min_radius, &l.pruned);
  l.params = params;
  const double fewer = std::pow(4.0, double(level));
  auto coarser = [&](std::uint32_t strands) {
    return std::max<std::uint32_t>(lod.min_root_strands, static_cast<std::uint32_t>(std::lround(strands / fewer)));
  };
  l.params.particles.max_root_strands = coarser(params.particles.max_root_strands);
  if (params.particles.root_strands > 0) l.params.particles.root_strands = coarser(params.particles.root_strands);
  if (params.particles.spacing > 0) l.params.particles.spacing = params.particles.spacing * std::pow(2.0, double(level));
  l.params.contours.slice_step = std::min(lod.max_slice_step, params.contours.slice_step * std::pow(2.0, double(level)));
  return l;
}

namespace {

/// The self-intersecting pairs of a run's mesh: the repair stage's count, or (on meshes it did
/// not count, above repair.count_pairs_up_to) a count over the whole mesh.
std::size_t pairs_left(const PipelineResult& r) {
  if (r.repair.counted) return r.repair.pairs_left;
  std::vector<std::uint32_t> all(r.mesh.mesh.triangles.size());
  std::iota(all.begin(), all.end(), 0u);
  return TriangleIntersections(r.mesh.mesh).pairs(all).size();
}

}  // namespace

PipelineResult mesh_lod(const RawSkeleton& raw, const PipelineParams& params, std::uint32_t level,
                        const LodParams& lod, const ProgressFn& progress, LodLevel* used,
                        const PipelineResult* finer) {
  LodLevel l = lod_level(raw, params, level, lod);
  PipelineResult r = run_pipeline(l.skeleton, l.params, progress);
  std::size_t pairs = pairs_left(r);
  if (pairs > 0 && l.params.contours.slice_step != params.contours.slice_step) {
    LodLevel finer_slices = l;
    finer_slices.params.contours.slice_step = params.contours.slice_step;
    PipelineResult again = run_pipeline(finer_slices.skeleton, finer_slices.params, progress);
    if (const std::size_t p = pairs_left(again); p < pairs) {
      pairs = p;
      r = std::move(again);
      l = std::move(finer_slices);
    }
  }
  l.rerun_pairs = pairs;
  // A clean finer level stays clean when simplified by collapses that refuse every crossing.
  // The target is the run's triangle count, at most three quarters of the finer level's: a
  // level is coarser than the one before even where the coarser settings did not thin it
  // (a tree whose strands were fewer than either level's cap).
  if (pairs > 0 && finer != nullptr) {
    SimplifyStats st;
    const std::size_t target = std::min(r.mesh.mesh.triangle_count(), finer->mesh.mesh.triangle_count() * 3 / 4);
    Mesh simpler = simplify_mesh(finer->mesh.mesh, {.target_triangles = target}, &st);
    if (st.pairs_after < pairs) {
      PipelineResult s = *finer;
      s.mesh.mesh = std::move(simpler);
      finish_normals(s.mesh.mesh, params.repair);
      s.mesh.triangle_kind.clear();
      s.mesh.stats.triangles = s.mesh.mesh.triangle_count();
      s.mesh.stats.vertices = s.mesh.mesh.vertex_count();
      s.repair.counted = true;
      s.repair.pairs_left = st.pairs_after;
      r = std::move(s);
      l.simplified = true;
      pairs = st.pairs_after;
    }
  }
  l.pairs = pairs;
  if (used != nullptr) *used = std::move(l);
  return r;
}

}  // namespace sm
