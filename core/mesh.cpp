#include "core/mesh.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <numbers>
#include <span>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/task_arena.h>

#include "core/math.h"
#include "core/union_find.h"

namespace sm {

VertexCorners vertex_corners(const Mesh& mesh) {
  const std::size_t nv = mesh.positions.size(), nf = mesh.triangles.size();
  VertexCorners out;
  out.begin.assign(nv + 1, 0);
  // A counting sort. The scattered writes are the cost, so large meshes split the vertices
  // into ranges, one task each: every task reads all triangles and writes only its vertices'
  // entries (corners in triangle order either way: the same table for any split).
  constexpr std::size_t kPerRange = 1 << 18;
  const std::size_t ranges =
      std::clamp<std::size_t>(std::min<std::size_t>(nv / kPerRange, tbb::this_task_arena::max_concurrency()), 1, 8);
  auto in_range = [&](std::size_t r, auto&& visit) {
    const std::uint32_t lo = static_cast<std::uint32_t>(r * nv / ranges),
                        hi = static_cast<std::uint32_t>((r + 1) * nv / ranges);
    for (std::size_t f = 0; f < nf; ++f) {
      for (std::uint32_t k = 0; k < 3; ++k) {
        const std::uint32_t v = mesh.triangles[f][k];
        if (v >= lo && v < hi) visit(v, static_cast<std::uint32_t>(3 * f + k));
      }
    }
  };
  tbb::parallel_for(std::size_t{0}, ranges,
                    [&](std::size_t r) { in_range(r, [&](std::uint32_t v, std::uint32_t) { ++out.begin[v + 1]; }); });
  for (std::size_t v = 0; v < nv; ++v) out.begin[v + 1] += out.begin[v];
  out.corner.resize(out.begin[nv]);
  std::vector<std::uint32_t> fill(out.begin.begin(), out.begin.end() - 1);
  tbb::parallel_for(std::size_t{0}, ranges, [&](std::size_t r) {
    in_range(r, [&](std::uint32_t v, std::uint32_t corner) { out.corner[fill[v]++] = corner; });
  });
  return out;
}

std::size_t unpaired_half_edges(const Mesh& mesh, const VertexCorners& corners) {
  const std::vector<std::uint32_t>& begin = corners.begin;
  return tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, mesh.positions.size(), 8192), std::size_t{0},
      [&](const tbb::blocked_range<std::size_t>& r, std::size_t count) {
        // (On the stack for the usual few corners: a vector's bookkeeping per vertex was a
        // third of the check.)
        constexpr std::uint32_t kOnStack = 32;
        std::uint32_t on_stack[2 * kOnStack];
        std::vector<std::uint32_t> on_heap;  // for a vertex of more corners
        for (std::size_t a = r.begin(); a != r.end(); ++a) {
          const std::uint32_t d = begin[a + 1] - begin[a];
          if (d > kOnStack) on_heap.resize(2 * d);
          std::uint32_t* const next = d > kOnStack ? on_heap.data() : on_stack;
          std::uint32_t* const prev = next + (d > kOnStack ? d : kOnStack);
          for (std::uint32_t k = 0; k < d; ++k) {
            const std::uint32_t c = corners.corner[begin[a] + k];
            const auto& t = mesh.triangles[c / 3];
            next[k] = t[(c % 3 + 1) % 3];
            prev[k] = t[(c % 3 + 2) % 3];
          }
          for (std::uint32_t k = 0; k < d; ++k) {
            const std::uint32_t b = next[k];
            std::uint32_t out = 0, in = 0;
            for (std::uint32_t x = 0; x < d; ++x) {
              out += next[x] == b;
              in += prev[x] == b;
            }
            if (out != 1 || in != 1) ++count;  // a->b more than once, or b->a not exactly once
          }
        }
        return count;
      },
      std::plus<>());
}

namespace {

/// The angle-weighted normal's weights at the corners of triangle (p0, p1, p2) of face normal
/// fn: each corner's angle over |fn| (twice the area), so that fn x w is the corner's angle
/// times the unit normal; 0 for a degenerate triangle. The third angle is what the first two
/// leave of pi (within 4e-6 radians), and |fn| is divided once (divisions were much of the
/// normals' cost: BM_Normals, 3.4 M triangles, 2 threads, 98 -> 76-78 ms; 11% fewer
/// instructions under callgrind).
inline std::array<double, 3> corner_weights(const glm::dvec3& p0, const glm::dvec3& p1, const glm::dvec3& p2,
                                            const glm::dvec3& fn) {
  const double len = glm::length(fn);
  if (!(len > 0)) return {0, 0, 0};
  const double a0 = fast_atan2(len, glm::dot(p1 - p0, p2 - p0)), a1 = fast_atan2(len, glm::dot(p2 - p1, p0 - p1));
  const double a2 = std::max(0.0, std::numbers::pi - a0 - a1);
  const double inv = 1.0 / len;
  return {a0 * inv, a1 * inv, a2 * inv};
}

// The direction of ray_crossing's rays: unlikely to run along a mesh's edges or faces (no
// axis, no diagonal). Set once at load, not tested for at every triangle.
const glm::dvec3 kRayDirection = glm::normalize(glm::dvec3(0.5773502691896258, 0.7071067811865476, 0.4082482904638631) +
                                                glm::dvec3(0.01234567, -0.00987654, 0.00543210));


/// A vertex normal is accepted when it is at most 89 degrees from each of its triangles' normals
/// (a degree of margin, so float32 storage cannot turn it past 90).
constexpr double kServeCosine = 0.0174524064372835;

/// The unit direction n with the largest min_i dot(n, u_i) over the unit vectors u (the centre
/// of the smallest spherical cap holding them), and that minimum. The optimum is fixed by one,
/// two or three of them (a vector, the bisector of two, the direction equally far from three),
/// so those candidates are tried; the first best one wins, so the result depends on the order
/// of u only. Triples are tried for up to 32 vectors.
std::pair<glm::dvec3, double> most_central_direction(const std::vector<glm::dvec3>& u) {
  glm::dvec3 best(0, 0, 1);
  double best_min = -2;
  auto consider = [&](const glm::dvec3& d) {
    const double l = glm::length(d);
    if (!(l > 1e-12)) return;
    const glm::dvec3 n = d / l;
    double m = 2;
    for (const glm::dvec3& x : u) {
      m = std::min(m, glm::dot(n, x));
      if (m <= best_min) return;
    }
    best = n;
    best_min = m;
  };
  const std::size_t k = u.size();
  for (std::size_t i = 0; i < k; ++i) consider(u[i]);
  for (std::size_t i = 0; i < k; ++i)
    for (std::size_t j = i + 1; j < k; ++j) consider(u[i] + u[j]);
  if (k <= 32) {
    for (std::size_t i = 0; i < k; ++i)
      for (std::size_t j = i + 1; j < k; ++j)
        for (std::size_t l = j + 1; l < k; ++l) {
          const glm::dvec3 c = glm::cross(u[j] - u[i], u[l] - u[i]);
          consider(c);
          consider(-c);
        }
  }
  return {best, best_min};
}

/// Where a vertex's normal (normals, unit) is more than 89 degrees from one of its triangles'
/// (issue 32: a black patch in shading), replaces it by the direction closest to all of them
/// (most_central_direction), if that is better. `faces_of(v, out)` fills the unit normals of
/// v's triangles of non-zero area.
template <class FacesOf>
void serve_every_face(std::span<const std::uint32_t> vertices, std::vector<glm::dvec3>& normals, FacesOf&& faces_of) {
  std::vector<glm::dvec3> u;
  for (const std::uint32_t v : vertices) {
    faces_of(v, u);
    std::sort(u.begin(), u.end(), [](const glm::dvec3& a, const glm::dvec3& b) {
      return a.x != b.x ? a.x < b.x : (a.y != b.y ? a.y < b.y : a.z < b.z);
    });  // the result depends on the set of triangles only, not on their order
    double worst = 2;
    for (const glm::dvec3& x : u) worst = std::min(worst, glm::dot(normals[v], x));
    if (u.empty() || worst >= kServeCosine) continue;
    const auto [n, m] = most_central_direction(u);
    if (m > worst) normals[v] = n;
  }
}
}  // namespace

std::vector<glm::dvec3> angle_weighted_normals(const Mesh& mesh) {
  return angle_weighted_normals(mesh, vertex_corners(mesh));
}

std::vector<glm::dvec3> angle_weighted_normals(const Mesh& mesh, const VertexCorners& vc) {
  // Each vertex sums the contributions of its corners in triangle order (fn x angle / |fn|,
  // the face normal fn weighted by the corner's angle), so the result is the same for any
  // number of threads. The triangles are visited once, in fixed chunks in parallel, each
  // triangle's three contributions computed together and added to its vertices' sums: by the
  // chunk holding the vertex's first triangle (vc: its first corner) in place, by any later
  // chunk into a queue of its own, added afterwards chunk by chunk (the vertices where chunks
  // meet: a few per chunk). The same values bit for bit as summing each vertex's corners on
  // its own (as before: a weight per corner, then a gather per vertex), in less time and
  // memory (BM_Normals, 3.4 M triangles, 2 threads: 93 -> 83 ms; no 82 MB of weights).
  const std::size_t nv = mesh.positions.size(), nf = mesh.triangles.size();
  std::vector<glm::dvec3> sum(nv, glm::dvec3(0));
  constexpr std::size_t kChunk = 1 << 15;
  const std::size_t chunks = (nf + kChunk - 1) / kChunk;
  struct Late {
    std::uint32_t v;
    glm::dvec3 contribution;
  };
  std::vector<std::vector<Late>> late(chunks);
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t k) {
    const std::size_t lo = k * kChunk, hi = std::min(nf, lo + kChunk);
    for (std::size_t f = lo; f < hi; ++f) {
      const auto& t = mesh.triangles[f];
      const glm::dvec3 &p0 = mesh.positions[t[0]], &p1 = mesh.positions[t[1]], &p2 = mesh.positions[t[2]];
      const glm::dvec3 fn = glm::cross(p1 - p0, p2 - p0);
      const std::array<double, 3> w = corner_weights(p0, p1, p2, fn);
      for (std::size_t c = 0; c < 3; ++c) {
        const glm::dvec3 contribution = w[c] == 0 ? glm::dvec3(0) : fn * w[c];
        const std::uint32_t v = t[c];
        if (vc.corner[vc.begin[v]] / 3 >= lo) {
          sum[v] += contribution;
        } else {
          late[k].push_back({v, contribution});
        }
      }
    }
  });
  for (const auto& queue : late) {
    for (const Late& l : queue) sum[l.v] += l.contribution;
  }
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nv, 4096), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      const double l = glm::length(sum[v]);
      sum[v] = l > 0 ? sum[v] * (1.0 / l) : glm::dvec3(0, 0, 1);
    }
  });
  // The vertices whose normal faces (nearly) away from one of their triangles: one pass over
  // the triangles marks them; they are few (a fold or needle at a crotch) and fixed in order.
  std::vector<std::uint8_t> away(nv, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, kChunk), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      const auto& t = mesh.triangles[f];
      const glm::dvec3 fn = mesh.face_normal(t);
      const double l = glm::length(fn);
      if (!(l > 0)) continue;
      for (const std::uint32_t v : t) {
        if (glm::dot(sum[v], fn) < kServeCosine * l) std::atomic_ref<std::uint8_t>(away[v]).store(1, std::memory_order_relaxed);
      }
    }
  });
  std::vector<std::uint32_t> fix;
  for (std::size_t v = 0; v < nv; ++v) {
    if (away[v]) fix.push_back(static_cast<std::uint32_t>(v));
  }
  serve_every_face(fix, sum, [&](std::uint32_t v, std::vector<glm::dvec3>& u) {
    u.clear();
    for (std::uint32_t x = vc.begin[v]; x < vc.begin[v + 1]; ++x) {
      const glm::dvec3 fn = mesh.face_normal(mesh.triangles[vc.corner[x] / 3]);
      const double l = glm::length(fn);
      if (l > 0 && std::isfinite(l)) u.push_back(fn / l);
    }
  });
  return sum;
}

namespace {

/// A unit float normal, as the writers store it (0, 0, 1 for a zero vector).
glm::vec3 unit_float(const glm::dvec3& n) { return glm::vec3(normalize_or(n, glm::dvec3(0, 0, 1))); }

/// One vertex's fan for split_vertex_normals: its corners' unit face normals (0 for zero
/// area), angle weights, and the fan edges joining two corners with their dihedral angles
/// (as cosines: no trigonometry per edge, where most of the time went).
struct Fan {
  struct Link {
    std::uint32_t i, j;  ///< positions of the two corners in the fan
    double cosine;       ///< of the angle between their triangles' normals (1 with a zero-area triangle)
    bool cut;            ///< a crease, or cut to split a group further
  };
  std::vector<glm::dvec3> unit;     ///< per corner
  std::vector<glm::dvec3> weighted; ///< per corner, where the fan splits: face normal times the corner's angle
  std::vector<std::uint32_t> next, prev, group, stack;
  std::vector<Link> links;
  UnionFind pieces{0};  ///< the corners of one group joined by its uncut edges
};

}  // namespace

SplitNormals split_vertex_normals(const Mesh& mesh, const VertexCorners& vc, std::span<const glm::dvec3> normals,
                                  double crease_angle, double max_angle) {
  // Each vertex on its own (its corners are written by it alone), in fixed ranges in parallel:
  // the same result for any number of threads.
  const std::size_t nv = mesh.positions.size(), nf = mesh.triangles.size();
  const double max_cos = std::cos(max_angle * std::numbers::pi / 180.0);
  // An edge is a crease when its angle exceeds crease_angle beyond rounding (an exact right
  // angle, dot 0, is no crease at 90 degrees, whose cosine is 6e-17).
  const double crease_cos = std::cos(crease_angle * std::numbers::pi / 180.0) - 1e-12;
  SplitNormals out;
  std::vector<std::array<glm::vec3, 3>> corner(nf);
  constexpr std::size_t kRange = 1 << 14;
  const std::size_t ranges = (nv + kRange - 1) / kRange;
  std::vector<std::size_t> split(ranges, 0), extra(ranges, 0), changed(ranges, 0);
  tbb::parallel_for(std::size_t{0}, ranges, [&](std::size_t r) {
    Fan fan;
    for (std::size_t v = r * kRange; v < std::min(nv, (r + 1) * kRange); ++v) {
      const std::uint32_t b = vc.begin[v], d = vc.begin[v + 1] - b;
      if (d == 0) continue;
      auto set = [&](std::uint32_t i, const glm::vec3& n) {
        const std::uint32_t c = vc.corner[b + i];
        corner[c / 3][c % 3] = n;
      };
      fan.unit.resize(d);
      fan.next.resize(d);
      fan.prev.resize(d);
      bool serves = true;  // the vertex normal is within max_angle of every triangle
      for (std::uint32_t i = 0; i < d; ++i) {
        const std::uint32_t c = vc.corner[b + i];
        const auto& t = mesh.triangles[c / 3];
        const std::uint32_t k = c % 3;
        fan.next[i] = t[(k + 1) % 3];
        fan.prev[i] = t[(k + 2) % 3];
        const glm::dvec3& p0 = mesh.positions[t[k]];
        const glm::dvec3 fn = glm::cross(mesh.positions[fan.next[i]] - p0, mesh.positions[fan.prev[i]] - p0);
        const double l = glm::length(fn);
        const bool area = l > 0 && std::isfinite(l);
        fan.unit[i] = area ? fn / l : glm::dvec3(0);
        if (area && glm::dot(normals[v], fan.unit[i]) < max_cos) serves = false;
      }
      // The fan's edges: corner i's edge to next[i] is corner j's from prev[j], where exactly
      // one corner each has it (boundary and non-manifold edges join nothing).
      fan.links.clear();
      for (std::uint32_t i = 0; i < d; ++i) {
        std::uint32_t j = d, arriving = 0, leaving = 0;
        for (std::uint32_t x = 0; x < d; ++x) {
          if (fan.prev[x] == fan.next[i]) j = x, ++arriving;
          leaving += fan.next[x] == fan.next[i];
        }
        if (arriving != 1 || leaving != 1 || j == i) continue;
        const bool area = fan.unit[i] != glm::dvec3(0) && fan.unit[j] != glm::dvec3(0);
        const double cosine = area ? glm::dot(fan.unit[i], fan.unit[j]) : 1.0;
        fan.links.push_back({i, j, cosine, cosine < crease_cos});
      }
      // The corners of group `g` joined by its edges not cut: each one's root (the least corner
      // of its piece) in fan.stack, in corner order.
      auto regroup = [&](std::uint32_t g) {
        fan.pieces.reset(d);
        for (const Fan::Link& e : fan.links) {
          if (fan.group[e.i] == g && fan.group[e.j] == g && !e.cut) fan.pieces.unite(e.i, e.j);
        }
        for (std::uint32_t i = 0; i < d; ++i) {
          if (fan.group[i] == g) fan.stack.push_back(fan.pieces.find(i));
        }
      };
      fan.group.assign(d, 0);
      fan.stack.clear();
      regroup(0);
      // fan.stack holds each corner's root; whole when every root is corner 0.
      const bool whole = std::all_of(fan.stack.begin(), fan.stack.end(), [](std::uint32_t x) { return x == 0; });
      if (whole && serves) {
        const glm::vec3 n = unit_float(normals[v]);
        for (std::uint32_t i = 0; i < d; ++i) set(i, n);
        continue;
      }
      ++changed[r];
      fan.weighted.resize(d);
      for (std::uint32_t i = 0; i < d; ++i) {
        const std::uint32_t c = vc.corner[b + i];
        const auto& t = mesh.triangles[c / 3];
        const std::uint32_t k = c % 3;
        const glm::dvec3 &p0 = mesh.positions[t[k]], &p1 = mesh.positions[t[(k + 1) % 3]],
                         &p2 = mesh.positions[t[(k + 2) % 3]];
        const glm::dvec3 fn = glm::cross(p1 - p0, p2 - p0);
        fan.weighted[i] = fan.unit[i] != glm::dvec3(0) ? fn * corner_weights(p0, p1, p2, fn)[0] : glm::dvec3(0);
      }
      // Split: groups named by their root corner; each one checked and cut further while a
      // triangle of it is more than max_angle from its normal.
      std::copy(fan.stack.begin(), fan.stack.end(), fan.group.begin());
      fan.stack.clear();
      std::vector<std::uint32_t>& todo = fan.next;  // (next and prev are no longer needed)
      todo.clear();
      for (std::uint32_t i = 0; i < d; ++i) {
        if (fan.group[i] == i) todo.push_back(i);
      }
      std::uint32_t groups = 0;
      while (!todo.empty()) {
        const std::uint32_t g = todo.back();
        todo.pop_back();
        glm::dvec3 sum(0);
        for (std::uint32_t i = 0; i < d; ++i) {
          if (fan.group[i] == g) sum += fan.weighted[i];
        }
        const double l = glm::length(sum);
        const glm::dvec3 n = l > 0 && std::isfinite(l) ? sum / l : normals[v];
        double sharpest = 2;  // the cosine of the largest angle of an edge inside the group
        bool ok = true;
        for (std::uint32_t i = 0; i < d; ++i) {
          if (fan.group[i] == g && fan.unit[i] != glm::dvec3(0) && glm::dot(n, fan.unit[i]) < max_cos) ok = false;
        }
        for (const Fan::Link& e : fan.links) {
          if (fan.group[e.i] == g && fan.group[e.j] == g && !e.cut) sharpest = std::min(sharpest, e.cosine);
        }
        if (ok || sharpest > 1.5) {
          ++groups;
          const glm::vec3 unit = unit_float(n);
          for (std::uint32_t i = 0; i < d; ++i) {
            if (fan.group[i] == g) set(i, unit);
          }
          continue;
        }
        // Cut the group's sharpest edges (every edge of that angle): the pieces follow (a closed
        // fan cut once stays whole and comes back with one edge fewer).
        for (Fan::Link& e : fan.links) {
          if (fan.group[e.i] == g && fan.group[e.j] == g && e.cosine <= sharpest) e.cut = true;
        }
        fan.stack.clear();
        regroup(g);
        std::uint32_t s = 0;
        for (std::uint32_t i = 0; i < d; ++i) {
          if (fan.group[i] != g) continue;
          const std::uint32_t root = fan.stack[s++];
          if (root == i) todo.push_back(i);
          fan.group[i] = root;
        }
      }
      if (groups > 1) {
        ++split[r];
        extra[r] += groups - 1;
      }
    }
  });
  std::size_t any = 0;
  for (std::size_t r = 0; r < ranges; ++r) {
    out.split_vertices += split[r];
    out.extra_normals += extra[r];
    any += changed[r];
  }
  if (any > 0) out.corner_normals = std::move(corner);
  return out;
}

void update_normals(Mesh& mesh, std::span<const std::uint32_t> vertices, std::span<const std::uint32_t> triangles) {
  // Each vertex's corners summed in triangle order, as angle_weighted_normals does.
  std::vector<std::uint32_t> list(vertices.begin(), vertices.end());
  std::sort(list.begin(), list.end());
  list.erase(std::unique(list.begin(), list.end()), list.end());
  std::vector<std::uint8_t> mark(mesh.positions.size(), 0);
  for (const std::uint32_t v : list) mark[v] = 1;
  std::vector<glm::dvec3> sum(list.size(), glm::dvec3(0));
  auto slot = [&](std::uint32_t v) { return std::lower_bound(list.begin(), list.end(), v) - list.begin(); };
  const std::size_t n = triangles.empty() ? mesh.triangles.size() : triangles.size();
  for (std::size_t k = 0; k < n; ++k) {
    const auto& t = mesh.triangles[triangles.empty() ? k : triangles[k]];
    if (!(mark[t[0]] | mark[t[1]] | mark[t[2]])) continue;
    const glm::dvec3 &p0 = mesh.positions[t[0]], &p1 = mesh.positions[t[1]], &p2 = mesh.positions[t[2]];
    const glm::dvec3 fn = glm::cross(p1 - p0, p2 - p0);
    const std::array<double, 3> w = corner_weights(p0, p1, p2, fn);
    for (std::size_t c = 0; c < 3; ++c) {
      if (mark[t[c]] && w[c] != 0) sum[slot(t[c])] += fn * w[c];
    }
  }
  for (std::size_t k = 0; k < list.size(); ++k) {
    const double l = glm::length(sum[k]);
    mesh.normals[list[k]] = l > 0 ? sum[k] * (1.0 / l) : glm::dvec3(0, 0, 1);
  }
  // As angle_weighted_normals: no normal facing away from one of its triangles.
  std::vector<std::vector<glm::dvec3>> faces(list.size());
  for (std::size_t k = 0; k < n; ++k) {
    const auto& t = mesh.triangles[triangles.empty() ? k : triangles[k]];
    if (!(mark[t[0]] | mark[t[1]] | mark[t[2]])) continue;
    const glm::dvec3 fn = mesh.face_normal(t);
    const double l = glm::length(fn);
    if (!(l > 0 && std::isfinite(l))) continue;
    for (const std::uint32_t v : t) {
      if (mark[v]) faces[static_cast<std::size_t>(slot(v))].push_back(fn / l);
    }
  }
  serve_every_face(list, mesh.normals, [&](std::uint32_t v, std::vector<glm::dvec3>& u) {
    u = faces[static_cast<std::size_t>(slot(v))];
  });
}

double winding_number(const Mesh& mesh, const glm::dvec3& p) {
  double w = 0;
  for (const auto& t : mesh.triangles)
    w += solid_angle(mesh.positions[t[0]] - p, mesh.positions[t[1]] - p, mesh.positions[t[2]] - p);
  return w / (4.0 * std::numbers::pi);
}

int ray_crossing(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& p) {
  const glm::dvec3& d = kRayDirection;
  // Moeller-Trumbore; a crossing is ambiguous within this relative margin of an edge, or of p.
  constexpr double kMargin = 1e-9;
  const glm::dvec3 e1 = b - a, e2 = c - a;
  const glm::dvec3 q = glm::cross(d, e2);
  const double det = glm::dot(e1, q);
  const glm::dvec3 s = p - a;
  const double scale = glm::dot(e1, e1) + glm::dot(e2, e2);
  if (std::abs(det) <= kMargin * scale) {
    // The ray runs along the triangle's plane: it misses the triangle unless p lies in that
    // plane too.
    const glm::dvec3 n = glm::cross(e1, e2);
    const double off = glm::dot(s, n);
    return off * off <= kMargin * kMargin * glm::dot(n, n) * (glm::dot(s, s) + scale) ? kRayAmbiguous : 0;
  }
  const double inv = 1.0 / det;
  const double u = glm::dot(s, q) * inv;
  if (u < -kMargin || u > 1 + kMargin) return 0;
  const glm::dvec3 r = glm::cross(s, e1);
  const double v = glm::dot(d, r) * inv;
  if (v < -kMargin || u + v > 1 + kMargin) return 0;
  const double h = glm::dot(e2, r) * inv;  // distance along the ray
  const double size = std::sqrt(scale);
  if (h < -kMargin * size) return 0;
  if (h <= kMargin * size || u <= kMargin || v <= kMargin || u + v >= 1 - kMargin) return kRayAmbiguous;
  // det = -dot(d, e1 x e2): leaving through the front when det < 0.
  return det < 0 ? 1 : -1;
}

bool inside_closed_mesh(const Mesh& mesh, const glm::dvec3& p) {
  int crossings = 0;
  for (const auto& t : mesh.triangles) {
    const int c = ray_crossing(mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]], p);
    if (c == kRayAmbiguous) return winding_number(mesh, p) >= 0.5;  // on the surface, or through an edge
    crossings += c;
  }
  return crossings >= 1;
}

std::vector<std::uint8_t> inside_closed_mesh(const Mesh& mesh, std::span<const glm::dvec3> points) {
  const std::vector<int> w = winding_numbers(mesh, points);
  std::vector<std::uint8_t> inside(w.size());
  for (std::size_t i = 0; i < w.size(); ++i) inside[i] = w[i] >= 1 ? 1 : 0;
  return inside;
}

std::vector<int> winding_numbers(const Mesh& mesh, std::span<const glm::dvec3> points) {
  const std::size_t n = points.size(), nf = mesh.triangles.size();
  std::vector<int> winding(n, 0);
  if (n == 0 || nf == 0) return winding;
  const glm::dvec3& d = kRayDirection;
  const glm::dvec3 au = glm::normalize(glm::cross(d, std::abs(d.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
  const glm::dvec3 av = glm::cross(d, au);
  auto shadow = [&](const glm::dvec3& p) { return glm::dvec2(glm::dot(p, au), glm::dot(p, av)); };
  // The points' shadows in a grid of four cells per point (CSR): they crowd where branches
  // overlap in the shadow, and a triangle's box is tested against every point in its cells
  // (BM_ThickNodesInside, 2 threads: 68 -> 57 ms against one cell per point; 16 cells per
  // point were slower again).
  std::vector<glm::dvec2> q(n);
  glm::dvec2 lo(HUGE_VAL), hi(-HUGE_VAL);
  for (std::size_t i = 0; i < n; ++i) {
    q[i] = shadow(points[i]);
    lo = glm::min(lo, q[i]);
    hi = glm::max(hi, q[i]);
  }
  const double extent = std::max({hi.x - lo.x, hi.y - lo.y, 1e-300});
  const double margin_abs = 1e-9 * extent;
  const std::size_t side = std::clamp<std::size_t>(static_cast<std::size_t>(2 * std::sqrt(double(n))), 1, 2048);
  const double cell = extent / double(side) * (1 + 1e-9);
  // (Clamped before the conversion, which then truncates as floor would: std::floor and the
  // division showed in a profile of the pass over the triangles.)
  const double per_cell = 1.0 / cell, last = double(side - 1);
  auto cell_of = [&](double t, double from) {
    return static_cast<std::size_t>(std::clamp((t - from) * per_cell, 0.0, last));
  };
  std::vector<std::uint32_t> begin(side * side + 1, 0), point(n);
  for (std::size_t i = 0; i < n; ++i) ++begin[cell_of(q[i].y, lo.y) * side + cell_of(q[i].x, lo.x) + 1];
  for (std::size_t c = 0; c + 1 < begin.size(); ++c) begin[c + 1] += begin[c];
  {
    std::vector<std::uint32_t> fill(begin.begin(), begin.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      point[fill[cell_of(q[i].y, lo.y) * side + cell_of(q[i].x, lo.x)]++] = static_cast<std::uint32_t>(i);
  }
  // Each triangle's crossings with the rays of the points whose shadow lies in its shadow's
  // box, summed per point (integers: the same for any split of the work).
  struct Counts {
    std::vector<int> crossings;
    std::vector<std::uint8_t> ambiguous;
  };
  tbb::enumerable_thread_specific<Counts> local([n] {
    return Counts{std::vector<int>(n, 0), std::vector<std::uint8_t>(n, 0)};
  });
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, nf, 1 << 14), [&](const tbb::blocked_range<std::size_t>& r) {
    Counts& counts = local.local();
    // (The tables as plain pointers: through the vectors, the compiler reloaded them at every
    // point, as the counts written might alias them.)
    const glm::dvec2* const shadows = q.data();
    const std::uint32_t* const cell_begin = begin.data();
    const std::uint32_t* const cell_point = point.data();
    int* const crossing_count = counts.crossings.data();
    std::uint8_t* const ambiguous_flag = counts.ambiguous.data();
    for (std::size_t f = r.begin(); f != r.end(); ++f) {
      const auto& t = mesh.triangles[f];
      const glm::dvec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
      const glm::dvec2 sa = shadow(a), sb = shadow(b), sc = shadow(c);
      glm::dvec2 bl = glm::min(sa, glm::min(sb, sc)), bh = glm::max(sa, glm::max(sb, sc));
      const double m = 1e-6 * ((bh.x - bl.x) + (bh.y - bl.y)) + margin_abs;
      bl -= glm::dvec2(m);
      bh += glm::dvec2(m);
      if (bh.x < lo.x || bh.y < lo.y || bl.x > hi.x || bl.y > hi.y) continue;
      const std::size_t x0 = cell_of(bl.x, lo.x), x1 = cell_of(bh.x, lo.x);
      const std::size_t y0 = cell_of(bl.y, lo.y), y1 = cell_of(bh.y, lo.y);
      for (std::size_t y = y0; y <= y1; ++y) {
        for (std::size_t x = x0; x <= x1; ++x) {
          for (std::uint32_t k = cell_begin[y * side + x], end = cell_begin[y * side + x + 1]; k < end; ++k) {
            const std::uint32_t i = cell_point[k];
            const glm::dvec2 qi = shadows[i];
            if (qi.x < bl.x || qi.x > bh.x || qi.y < bl.y || qi.y > bh.y) continue;
            const int crossing = ray_crossing(a, b, c, points[i]);
            if (crossing == kRayAmbiguous)
              ambiguous_flag[i] = 1;
            else
              crossing_count[i] += crossing;
          }
        }
      }
    }
  });
  std::vector<int> crossings(n, 0);
  std::vector<std::uint8_t> ambiguous(n, 0);
  for (const Counts& c : local) {
    for (std::size_t i = 0; i < n; ++i) {
      crossings[i] += c.crossings[i];
      ambiguous[i] |= c.ambiguous[i];
    }
  }
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    winding[i] = ambiguous[i] ? static_cast<int>(std::lround(winding_number(mesh, points[i]))) : crossings[i];
  });
  return winding;
}

double float_grid(double reach) {
  if (!(reach > 0) || !std::isfinite(reach)) return 0x1p-60;
  return std::ldexp(1.0, std::ilogb(reach) + 1 - 24);  // 2^(floor(log2 reach) + 1) >= reach, over 2^24
}

double export_grid_spacing(double half_extent) { return 16.0 * float_grid(half_extent); }

namespace {

/// std::nearbyint(x) in the default rounding mode (to nearest, ties to even; the sign of a
/// zero kept), without a call: below 2^51 in size, adding and taking away 1.5 x 2^52 leaves
/// x rounded to the integer grid of doubles in [2^52, 2^53); larger doubles are integers.
inline double round_to_integer(double x) {
  constexpr double kShift = 0x1.8p52;
  if (!(std::abs(x) < 0x1p51)) return x;  // an integer already, or not finite
  return std::copysign((x + kShift) - kShift, x);
}

}  // namespace

glm::dvec3 snap_to_grid(const glm::dvec3& p, double spacing) {
  // (spacing a power of two: dividing by it is multiplying by its exact inverse. The
  // float-grid pass over every vertex made three library calls and three divisions each.)
  const double inv = 1.0 / spacing;
  return glm::dvec3(round_to_integer(p.x * inv), round_to_integer(p.y * inv), round_to_integer(p.z * inv)) * spacing;
}

}  // namespace sm
