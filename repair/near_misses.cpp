// Step 3 of the repair stage, near misses: a local push of the surface over thick nodes just outside it (near_misses.h).

#include "repair/near_misses.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <optional>
#include <unordered_map>
#include <utility>
#include <vector>

#include <glm/glm.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/math.h"
#include "core/mesh.h"
#include "core/report.h"
#include "meshcheck/checks.h"
#include "meshcheck/intersections.h"

namespace sm {
namespace {

using glm::dvec3;

/// Farthest a node may lie outside the surface to be pushed over, relative to its radius.
constexpr double kMaxMiss = 1.0;
/// How far past the node the pushed surface goes, relative to its radius: the first that
/// turns no triangle over and adds no crossing. (0.25 alone: 4 of 9 pushes kept on agraf
/// with configs/preview.json, the others turning a triangle or adding pairs.)
constexpr double kMargins[] = {0.25, 0.1, 0.03};
/// The triangles within this many radii of a node outside are gathered in one pass; the
/// pushes' neighbourhoods are taken from them where they fit (a push's reach is a few radii,
/// but the nearest triangle's corners can lie 9 radii away on a thick branch's long triangles).
constexpr double kGather = 32.0;
/// Rounds of pushes (a push whose neighbourhood overlaps an earlier one's waits for the next).
constexpr int kRounds = 4;
/// More thick nodes outside than this are a tangle of branches, not near misses.
constexpr std::size_t kMaxNodes = 64;

struct Nearest {
  double distance = std::numeric_limits<double>::infinity();
  std::uint32_t triangle = std::numeric_limits<std::uint32_t>::max();
  dvec3 point{0.0};
  /// Smaller distance first, then the lower triangle index: the same for any split of the work.
  [[nodiscard]] bool better_than(const Nearest& o) const {
    return distance < o.distance || (distance == o.distance && triangle < o.triangle);
  }
};

/// One node's push.
struct Push {
  std::uint32_t thick_index = 0;  // in the list of thick nodes
  std::uint32_t node = 0;
  dvec3 at{0.0};                        // the node
  dvec3 q{0.0};                         // the nearest surface point
  std::uint32_t triangle = 0;           // the triangle it lies on
  dvec3 direction{0.0};                 // from q towards the node (unit)
  double depth = 0;                     // the move of the nearest triangle's corners
  double reach = 0;                     // other vertices move less with their distance from q, none this far
  double extent = 0;                    // the farthest a moved vertex lies from q (a corner may lie beyond reach)
  std::vector<std::uint32_t> vertices;  // moved, with their old positions
  std::vector<dvec3> old;
  std::vector<std::uint32_t> triangles;   // with a moved corner
  std::vector<std::uint32_t> gathered;    // the triangles within `gather` of the node
  double gather = 0;                      // kGather x the node's radius
  std::vector<std::uint32_t> around;      // the triangles near the push (see below)
  dvec3 lo{0.0}, hi{0.0};                 // the box of the moved triangles, grown by the move
  std::vector<std::uint32_t> near_nodes;  // thick nodes inside before, near enough to be affected
  std::size_t pairs_before = 0;
  bool ok = true;
};

/// The share of the move of a vertex `distance` from q (not a corner of the nearest triangle).
double weight(const Push& p, double distance) {
  if (distance >= p.reach) return 0.0;
  const double x = 1.0 - distance / p.reach;
  return x * x * (3.0 - 2.0 * x);
}

void undo(Mesh& mesh, const Push& p) {
  for (std::size_t k = 0; k < p.vertices.size(); ++k) mesh.positions[p.vertices[k]] = p.old[k];
}

/// The vertices `p` moves: over the triangles around it (`around`), from the nearest
/// triangle's corners, every vertex within its reach (a breadth-first walk, so the far side of
/// a thin branch or a neighbouring branch within the reach, not joined to q within it, stays);
/// and the triangles with a moved corner.
void select_vertices(const Mesh& mesh, Push& p) {
  std::unordered_map<std::uint32_t, std::vector<std::uint32_t>> incident;
  for (const std::uint32_t f : p.around) {
    for (const std::uint32_t v : mesh.triangles[f]) incident[v].push_back(f);
  }
  const auto& corners = mesh.triangles[p.triangle];
  std::unordered_map<std::uint32_t, bool> seen;
  std::vector<std::uint32_t> queue;
  for (const std::uint32_t v : corners) {
    if (seen.emplace(v, true).second) queue.push_back(v);
  }
  for (std::size_t k = 0; k < queue.size(); ++k) {
    const std::uint32_t v = queue[k];
    const bool corner = std::find(corners.begin(), corners.end(), v) != corners.end();
    if (!corner && glm::length(mesh.positions[v] - p.q) >= p.reach) continue;
    p.vertices.push_back(v);
    for (const std::uint32_t f : incident[v]) {
      for (const std::uint32_t w : mesh.triangles[f]) {
        if (seen.emplace(w, true).second) queue.push_back(w);
      }
    }
  }
  std::sort(p.vertices.begin(), p.vertices.end());
  for (const std::uint32_t f : p.around) {
    const auto& t = mesh.triangles[f];
    if (std::any_of(t.begin(), t.end(),
                    [&](std::uint32_t v) { return std::binary_search(p.vertices.begin(), p.vertices.end(), v); }))
      p.triangles.push_back(f);
  }
}

/// Moves p's vertices from their old positions by its current depth and reach: the nearest
/// triangle's corners all the way, the others by weight(), onto the float grid.
void move(Mesh& mesh, const Push& p, double grid) {
  const auto& corners = mesh.triangles[p.triangle];
  for (std::size_t k = 0; k < p.vertices.size(); ++k) {
    const bool corner = std::find(corners.begin(), corners.end(), p.vertices[k]) != corners.end();
    const dvec3& x = p.old[k];
    const dvec3 moved = x + p.direction * (p.depth * (corner ? 1.0 : weight(p, glm::length(x - p.q))));
    mesh.positions[p.vertices[k]] = grid > 0 ? snap_to_grid(moved, grid) : moved;
  }
}

/// For each of `count` queries, the triangles for which `meets(query, lo, hi)` holds (lo, hi:
/// the triangle's box), in increasing order: one pass over the triangles, in fixed chunks in
/// parallel.
template <class Meets>
std::vector<std::vector<std::uint32_t>> triangles_meeting(const Mesh& mesh, std::size_t count, Meets&& meets) {
  const std::size_t nf = mesh.triangles.size();
  constexpr std::size_t kChunk = 1 << 15;
  const std::size_t chunks = (nf + kChunk - 1) / kChunk;
  std::vector<std::vector<std::pair<std::uint32_t, std::uint32_t>>> found(chunks);  // (query, triangle)
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t k) {
    for (std::size_t f = k * kChunk, end = std::min(nf, f + kChunk); f < end; ++f) {
      const auto& t = mesh.triangles[f];
      const dvec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
      const dvec3 lo = glm::min(a, glm::min(b, c)), hi = glm::max(a, glm::max(b, c));
      for (std::size_t i = 0; i < count; ++i) {
        if (meets(i, lo, hi)) found[k].emplace_back(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(f));
      }
    }
  });
  std::vector<std::vector<std::uint32_t>> out(count);
  for (const auto& list : found) {
    for (const auto& [i, f] : list) out[i].push_back(f);
  }
  return out;
}

/// Each push's `around`: the triangles for which `meets(push, lo, hi)` holds, taken from the
/// triangles gathered around its node where `covered(push)` says they hold all of them, else
/// from one pass over the mesh.
template <class Meets, class Covered>
void triangles_near(const Mesh& mesh, std::vector<Push>& pushes, Meets&& meets, Covered&& covered) {
  std::vector<std::size_t> far;
  for (std::size_t i = 0; i < pushes.size(); ++i) {
    Push& p = pushes[i];
    if (!covered(p)) {
      far.push_back(i);
      continue;
    }
    p.around.clear();
    for (const std::uint32_t f : p.gathered) {
      const auto& t = mesh.triangles[f];
      const dvec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
      if (meets(p, glm::min(a, glm::min(b, c)), glm::max(a, glm::max(b, c)))) p.around.push_back(f);
    }
  }
  if (far.empty()) return;
  auto lists = triangles_meeting(
      mesh, far.size(), [&](std::size_t k, const dvec3& lo, const dvec3& hi) { return meets(pushes[far[k]], lo, hi); });
  for (std::size_t k = 0; k < far.size(); ++k) pushes[far[k]].around = std::move(lists[k]);
}

/// Squared distance from p to the box [lo, hi] (0 inside).
double box_distance2(const dvec3& p, const dvec3& lo, const dvec3& hi) {
  const dvec3 d = glm::max(glm::max(lo - p, p - hi), dvec3(0));
  return glm::dot(d, d);
}

/// The signed crossings of the ray from p (core/mesh.h ray_crossing) with `triangles`; nullopt
/// where one is ambiguous.
std::optional<int> crossings(const Mesh& mesh, const std::vector<std::uint32_t>& triangles, const dvec3& p) {
  int sum = 0;
  for (const std::uint32_t f : triangles) {
    const auto& t = mesh.triangles[f];
    const int c = ray_crossing(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]], p);
    if (c == kRayAmbiguous) return std::nullopt;
    sum += c;
  }
  return sum;
}

}  // namespace

std::string to_text(const NearMissStats& s) {
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "%zu -> %zu thick nodes outside; %zu push(es) of the surface kept (%zu vertices moved), %zu undone, "
                "in %.3f s",
                s.outside_before, s.outside_after, s.covered, s.moved_vertices, s.refused, s.seconds);
  return buf;
}

NearMissStats cover_near_misses(MeshResult& result, const Skeleton& skeleton) {
  NearMissStats stats;
  stats.tried = true;
  Stopwatch clock;
  Mesh& mesh = result.mesh;
  const std::size_t nf = mesh.triangles.size();
  if (nf == 0 || skeleton.empty()) return stats;

  const std::vector<std::uint32_t> thick = thick_node_ids(skeleton);
  std::vector<dvec3> at;
  at.reserve(thick.size());
  for (const std::uint32_t n : thick) at.push_back(skeleton.position[n]);
  std::vector<std::uint8_t> inside = inside_closed_mesh(mesh, at);
  std::vector<std::uint32_t> todo;  // indices into `thick`
  for (std::size_t k = 0; k < thick.size(); ++k) {
    if (!inside[k]) todo.push_back(static_cast<std::uint32_t>(k));
  }
  stats.outside_before = stats.outside_after = todo.size();
  auto name_left = [&] {
    for (std::size_t k = 0; k < thick.size(); ++k) {
      if (!inside[k]) stats.left.push_back(NodeId(thick[k]));
    }
  };
  if (todo.empty() || todo.size() > kMaxNodes) {
    name_left();
    stats.seconds = clock.lap();
    return stats;
  }

  const TriangleIntersections intersections(mesh);
  std::vector<std::uint32_t> renormal, local;  // for the normals: the kept pushes' vertices and triangles
  // Rounds: a node whose push would overlap an earlier one's waits for the next round.
  for (int round = 0; round < kRounds && !todo.empty(); ++round) {
    const std::vector<std::uint32_t> outside = std::move(todo);
    todo.clear();
    // The triangles near each node outside (one pass), and the nearest surface point among
    // them, within kMaxMiss x its radius.
    const std::size_t no = outside.size();
    // (Squared distances, each node's position and reach looked up once: this pass visits
    // every triangle.)
    std::vector<dvec3> centre(no);
    std::vector<double> reach2(no);
    for (std::size_t i = 0; i < no; ++i) {
      centre[i] = at[outside[i]];
      const double reach = kGather * skeleton.radius[thick[outside[i]]];
      reach2[i] = reach * reach;
    }
    std::vector<std::vector<std::uint32_t>> gathered = triangles_meeting(
        mesh, no,
        [&](std::size_t i, const dvec3& lo, const dvec3& hi) { return box_distance2(centre[i], lo, hi) <= reach2[i]; });
    std::vector<Nearest> nearest(no);
    for (std::size_t i = 0; i < no; ++i) {
      const dvec3& p = at[outside[i]];
      const double limit = kMaxMiss * skeleton.radius[thick[outside[i]]];
      for (const std::uint32_t f : gathered[i]) {
        const auto& t = mesh.triangles[f];
        const dvec3 q = closest_on_triangle(p, mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]);
        const Nearest cand{glm::length(p - q), f, q};
        if (cand.distance <= limit && cand.better_than(nearest[i])) nearest[i] = cand;
      }
    }

    // The pushes, their reaches apart.
    std::vector<Push> pushes;
    for (std::size_t i = 0; i < no; ++i) {
      const Nearest& n = nearest[i];
      if (n.triangle == std::numeric_limits<std::uint32_t>::max()) continue;  // not a near miss
      Push p;
      p.thick_index = outside[i];
      p.node = thick[outside[i]];
      p.at = at[outside[i]];
      p.q = n.point;
      p.triangle = n.triangle;
      p.gathered = std::move(gathered[i]);
      p.gather = kGather * skeleton.radius[p.node];
      const dvec3 fn = mesh.face_normal(mesh.triangles[n.triangle]);
      const double fl = glm::length(fn);
      p.direction = n.distance > 0 ? (p.at - p.q) / n.distance : (fl > 0 ? fn / fl : dvec3(0));
      if (p.direction == dvec3(0)) continue;
      const double r = skeleton.radius[p.node];
      p.depth = n.distance + kMargins[0] * r;  // the largest move: the neighbourhoods below hold for all
      p.reach = r + 2.0 * p.depth;
      p.extent = p.reach;
      for (const std::uint32_t v : mesh.triangles[n.triangle])
        p.extent = std::max(p.extent, glm::length(mesh.positions[v] - p.q));
      bool apart = true;
      for (const Push& o : pushes) apart = apart && glm::length(o.q - p.q) > o.extent + p.extent + o.depth + p.depth;
      if (!apart) {
        todo.push_back(outside[i]);
        continue;
      }
      pushes.push_back(std::move(p));
    }
    if (pushes.empty()) continue;

    // Per push, the triangles whose box meets its extent around q.
    triangles_near(
        mesh, pushes,
        [](const Push& p, const dvec3& lo, const dvec3& hi) {
          return box_distance2(p.q, lo, hi) <= p.extent * p.extent;
        },
        [](const Push& p) { return p.extent + glm::length(p.at - p.q) <= p.gather; });

    for (Push& p : pushes) select_vertices(mesh, p);

    // The triangles a moved one may come to meet: those whose box meets the moved triangles'
    // boxes, grown by the move (a long triangle with one corner moved reaches far beyond q).
    for (Push& p : pushes) {
      p.lo = dvec3(std::numeric_limits<double>::infinity());
      p.hi = -p.lo;
      for (const std::uint32_t f : p.triangles) {
        for (const std::uint32_t v : mesh.triangles[f]) {
          p.lo = glm::min(p.lo, mesh.positions[v]);
          p.hi = glm::max(p.hi, mesh.positions[v]);
        }
      }
      p.lo -= dvec3(p.depth);
      p.hi += dvec3(p.depth);
      // The thick nodes inside now that the push might carry out of the surface.
      for (std::size_t k = 0; k < thick.size(); ++k) {
        if (inside[k] && glm::all(glm::lessThanEqual(p.lo, at[k])) && glm::all(glm::lessThanEqual(at[k], p.hi)))
          p.near_nodes.push_back(static_cast<std::uint32_t>(k));
      }
    }
    triangles_near(
        mesh, pushes,
        [](const Push& p, const dvec3& lo, const dvec3& hi) {
          return glm::all(glm::lessThanEqual(lo, p.hi)) && glm::all(glm::lessThanEqual(p.lo, hi));
        },
        [](const Push& p) {  // the box's farthest corner within the gathered distance
          const dvec3 far = glm::max(glm::abs(p.lo - p.at), glm::abs(p.hi - p.at));
          return glm::length(far) <= p.gather;
        });
    for (Push& p : pushes) p.pairs_before = intersections.pairs(p.around).size();

    // Move, and check push by push: no moved triangle turned over or degenerate, no more
    // crossing pairs around, the node inside and no thick node near it lost. Only the moved
    // triangles change the crossings of a ray (core/mesh.h ray_crossing): a point's count
    // changes by theirs after minus before, so the node (outside: 0) is inside where that is
    // positive, and a node inside stays so where it is not negative; the whole mesh is tested
    // only where a crossing is ambiguous or a node inside may have left.
    std::vector<dvec3> unsure_at;
    std::vector<std::uint32_t> unsure_push;
    for (std::size_t i = 0; i < pushes.size(); ++i) {
      Push& p = pushes[i];
      std::vector<dvec3> normal_before;
      normal_before.reserve(p.triangles.size());
      for (const std::uint32_t f : p.triangles) normal_before.push_back(mesh.face_normal(mesh.triangles[f]));
      std::vector<std::optional<int>> before;
      before.push_back(crossings(mesh, p.triangles, p.at));
      for (const std::uint32_t k : p.near_nodes) before.push_back(crossings(mesh, p.triangles, at[k]));
      p.old.reserve(p.vertices.size());
      for (const std::uint32_t v : p.vertices) p.old.push_back(mesh.positions[v]);
      const double miss = glm::length(p.at - p.q), r = skeleton.radius[p.node];
      // The largest margin first; a smaller one where a triangle turns or a crossing appears.
      for (const double margin : kMargins) {
        p.ok = true;
        p.depth = miss + margin * r;
        p.reach = r + 2.0 * p.depth;
        move(mesh, p, result.grid);
        for (std::size_t k = 0; k < p.triangles.size() && p.ok; ++k) {
          const dvec3 after = mesh.face_normal(mesh.triangles[p.triangles[k]]);
          const double la = glm::length(after), lb = glm::length(normal_before[k]);
          p.ok = la > 1e-3 * lb && glm::dot(after, normal_before[k]) > 0;
        }
        if (p.ok) p.ok = intersections.pairs(p.around).size() <= p.pairs_before;
        std::vector<dvec3> unsure;
        for (std::size_t k = 0; k < before.size() && p.ok; ++k) {
          const dvec3& x = k == 0 ? p.at : at[p.near_nodes[k - 1]];
          const std::optional<int> after = crossings(mesh, p.triangles, x);
          if (!before[k] || !after) {
            unsure.push_back(x);
          } else if (k == 0) {
            p.ok = *after - *before[k] > 0;
          } else if (*after - *before[k] < 0) {
            unsure.push_back(x);
          }
        }
        if (p.ok) {
          unsure_at.insert(unsure_at.end(), unsure.begin(), unsure.end());
          unsure_push.insert(unsure_push.end(), unsure.size(), static_cast<std::uint32_t>(i));
          break;
        }
        undo(mesh, p);
      }
    }
    if (!unsure_at.empty()) {
      const std::vector<std::uint8_t> now = inside_closed_mesh(mesh, unsure_at);
      for (std::size_t k = 0; k < unsure_at.size(); ++k) {
        Push& p = pushes[unsure_push[k]];
        if (!now[k] && p.ok) {
          p.ok = false;
          undo(mesh, p);
        }
      }
    }

    for (const Push& p : pushes) {
      if (!p.ok) {
        ++stats.refused;
        continue;
      }
      ++stats.covered;
      inside[p.thick_index] = 1;
      stats.moved_vertices += p.vertices.size();
      for (const std::uint32_t f : p.triangles)
        renormal.insert(renormal.end(), mesh.triangles[f].begin(), mesh.triangles[f].end());
      local.insert(local.end(), p.around.begin(), p.around.end());
    }
  }
  stats.outside_after = stats.outside_before - stats.covered;
  name_left();
  // Every triangle at a corner of a moved triangle meets the moved triangles' box: `around`.
  std::sort(local.begin(), local.end());
  local.erase(std::unique(local.begin(), local.end()), local.end());
  if (!mesh.normals.empty() && !renormal.empty()) update_normals(mesh, renormal, local);
  stats.seconds = clock.lap();
  return stats;
}

}  // namespace sm
