// Meshing: strips, branch fusion, caps, normals and UVs (Interactive Invigoration, Li et al.).

#include "meshing/meshing.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <mutex>
#include <numbers>
#include <numeric>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include "core/errors.h"
#include "core/math.h"

namespace sm {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;
/// Stacked junctions are merged only when every upper loop has at least this many vertices.
constexpr std::size_t kMinMergedLoop = 6;

/// Drops the entries of [0, n) that `keep` refuses by filling each such hole with the last
/// kept entry after it (`move(from, to)`); returns how many are kept, now [0, count). Where
/// the holes are few, so are the moves (rather than shifting every entry after the first hole).
template <class Keep, class Move>
std::size_t fill_holes(std::size_t n, Keep&& keep, Move&& move) {
  std::size_t last = n;  // the entries from `last` on are done with
  for (std::size_t hole = 0; hole < last; ++hole) {
    if (keep(hole)) continue;
    while (last > hole + 1 && !keep(last - 1)) --last;
    if (last <= hole + 1) return hole;  // nothing kept after the hole
    --last;
    move(last, hole);
  }
  return last;
}

/// Signed angle difference wrapped into (-pi, pi].
double wrap_pi(double a) {
  while (a > std::numbers::pi) a -= kTwoPi;
  while (a <= -std::numbers::pi) a += kTwoPi;
  return a;
}

/// Unwrapped angles of loop vertices (raw angles in (-pi, pi] given per vertex id), relative
/// to `ref`; entry k = m is the first one plus 2 pi, so a full turn ends where it started.
/// Returns false (and `a` is meaningless) unless the loop winds once around the point the angles
/// are measured from: a concave outline (contours' fallback) may pass beside or behind its
/// centroid, and its angles then turn back or jump, and do not end one turn on.
bool unwrapped_angles(const std::vector<std::uint32_t>& loop, const std::vector<double>& raw_angle, double ref,
                      std::vector<double>& a) {
  const std::size_t m = loop.size();
  a.resize(m + 1);
  double prev = 0;
  for (std::size_t k = 0; k < m; ++k) {
    const double raw = raw_angle[loop[k]];
    a[k] = k == 0 ? wrap_pi(raw - ref) : a[k - 1] + wrap_pi(raw - prev);
    prev = raw;
  }
  const double turn = a[m - 1] + wrap_pi(raw_angle[loop[0]] - prev) - a[0];
  a[m] = a[0] + kTwoPi;
  return std::abs(turn - kTwoPi) < 0.5 * kTwoPi;
}

struct AngleGuard {
  std::vector<double> lower, upper;
  double tolerance = 0;
};

/// The strip between two closed loops (see stitch_loops in the header). With a guard, a
/// greedy choice that would run against the angular order around the branch axis by more
/// than the tolerance is overruled, which keeps the strip from folding over itself when the
/// two loops are offset or differently sampled.
///
/// The strip is a monotone path from the edge (lower[0], upper[0]) round to itself, and the
/// edge (lower[i], upper[0]) is on it at both ends of a run of upper advances from j = 0 all the
/// way to j = n at one i: a fan of every upper vertex around one lower vertex, each edge of
/// which is then used four times (and likewise a run of lower advances round one upper vertex).
/// Neither choice can ever be right, so neither is made, whatever the greedy rule and the guard
/// say (as in stitch_open): upper may not reach its end while lower is still at the vertex where
/// upper left its start, nor lower its end while upper is still where lower left its start.
void stitch(const std::vector<std::uint32_t>& lower, const std::vector<std::uint32_t>& upper,
            const std::vector<glm::dvec3>& pos, std::vector<Mesh::Triangle>& out, const AngleGuard* guard) {
  const std::size_t m = lower.size(), n = upper.size();
  std::size_t i = 0, j = 0;
  std::size_t i_left_upper0 = 0, j_left_lower0 = 0;  // where upper left upper[0], lower left lower[0]
  while (i < m || j < n) {
    const std::uint32_t p = lower[i % m], q = upper[j % n];
    const std::uint32_t p1 = lower[(i + 1) % m], q1 = upper[(j + 1) % n];
    const bool can_lower = i < m && !(i + 1 == m && j == j_left_lower0 && n > 1);
    const bool can_upper = j < n && !(j + 1 == n && i == i_left_upper0 && m > 1);
    bool advance_lower;
    if (!can_upper || !can_lower) {
      advance_lower = can_lower || (!can_upper && i < m);
    } else {
      const double dl = glm::length(pos[p1] - pos[q]);
      const double du = glm::length(pos[p] - pos[q1]);
      advance_lower = dl <= du;
      if (guard) {
        const double al = guard->lower[i + 1], au = guard->upper[j + 1];
        if (advance_lower && al > au + guard->tolerance) advance_lower = false;
        if (!advance_lower && au > al + guard->tolerance) advance_lower = true;
      }
    }
    if (advance_lower) {
      out.push_back({p, p1, q});
      ++i;
      if (j == 0) i_left_upper0 = i;
    } else {
      out.push_back({p, q1, q});
      ++j;
      if (i == 0) j_left_lower0 = j;
    }
  }
}

/// The strip between two open chains P[0..m) and Q[0..n) from the edge (P0, Q0) to the edge
/// (P[m-1], Q[n-1]), greedy shortest diagonal. Q may start and end at the same vertex (the
/// crotch vertex of a fusion), so no P vertex may connect to both Q0 and Q[n-1]: Q enters
/// its last vertex only once P has moved past the last P vertex connected to Q0, and P may
/// not reach its end while Q is still at its start.
void stitch_open(const std::vector<std::uint32_t>& P, const std::vector<std::uint32_t>& Q,
                 const std::vector<glm::dvec3>& pos, std::vector<Mesh::Triangle>& out) {
  const std::size_t m = P.size(), n = Q.size();
  std::size_t i = 0, j = 0;
  std::size_t last_on_q0 = 0;  // the last P index connected to Q[0]
  while (i + 1 < m || j + 1 < n) {
    const bool can_p = i + 1 < m && !(j == 0 && i + 1 == m - 1 && n > 1);
    const bool can_q = j + 1 < n && !(j + 1 == n - 1 && i <= last_on_q0 && m > 1);
    bool advance_p;
    if (can_p && can_q) {
      advance_p = glm::length(pos[P[i + 1]] - pos[Q[j]]) <= glm::length(pos[P[i]] - pos[Q[j + 1]]);
    } else {
      advance_p = can_p || (!can_q && i + 1 < m);
    }
    if (advance_p) {
      out.push_back({P[i], P[i + 1], Q[j]});
      ++i;
      if (j == 0) last_on_q0 = i;
    } else {
      out.push_back({P[i], Q[j + 1], Q[j]});
      ++j;
    }
  }
}

/// Branch fusion. `lower` is the loop below the split, `a` and `b` the
/// first loops of the two child tubes (all counter-clockwise seen from the tip side; `tangent`
/// points up the parent branch); `side` says for each lower vertex whose bundle its strand
/// belongs to (0 = a, 1 = b, 2 = neither; may be empty).
///
/// The crotch is the vertex a* of loop a nearest to b's centre and the vertex b* of b nearest
/// to a's centre. The lower loop is cut at two vertices l_b and l_f into a chain on a's side
/// and one on b's: where the strands change from one bundle to the other (the waist of the
/// union), or, without that information, where the lower loop is crossed by the line through
/// the crotch across the a-to-b direction. Strip A joins l_b..l_f (counter-clockwise) to the
/// whole loop a from a* back to a*; strip B joins l_f..l_b to b from b* back to b*; the two
/// special triangles (l_f, b*, a*) and (l_b, a*, b*) close the crotch. Every edge is used
/// exactly twice.
void fuse_chains(const std::vector<std::uint32_t>& lower, const std::vector<std::uint32_t>& a,
                 const std::vector<std::uint32_t>& b, const std::vector<std::uint8_t>& side,
                 const std::vector<glm::dvec3>& pos, const glm::dvec3& tangent, std::vector<Mesh::Triangle>& out) {
  auto centroid = [&](const std::vector<std::uint32_t>& ids) {
    glm::dvec3 c(0);
    for (auto v : ids) c += pos[v];
    return c / double(ids.size());
  };
  auto nearest = [&](const std::vector<std::uint32_t>& ids, const glm::dvec3& q) {
    std::size_t best = 0;
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < ids.size(); ++k) {
      const double e = glm::dot(pos[ids[k]] - q, pos[ids[k]] - q);
      if (e < d) {
        d = e;
        best = k;
      }
    }
    return best;
  };
  const glm::dvec3 ca = centroid(a), cb = centroid(b);
  const std::size_t ia = nearest(a, cb), ib = nearest(b, ca);
  const std::size_t m = lower.size();

  // Cut the lower loop: preferably where its strands change bundle.
  std::size_t lb = m, lf = m;
  if (side.size() == m) {
    // Resolve "neither" vertices to the side of the previous labelled vertex.
    std::vector<int> s(m, -1);
    int last = -1;
    for (std::size_t pass = 0; pass < 2; ++pass) {
      for (std::size_t k = 0; k < m; ++k) {
        if (side[k] < 2) last = side[k];
        if (s[k] < 0 && last >= 0) s[k] = side[k] < 2 ? side[k] : last;
      }
    }
    std::size_t a_to_b = 0, b_to_a = 0, changes = 0;
    for (std::size_t k = 0; k < m && s[0] >= 0; ++k) {
      const int x = s[k], y = s[(k + 1) % m];
      if (x != y) {
        ++changes;
        if (x == 0)
          a_to_b = k;  // last vertex of the a-run
        else
          b_to_a = (k + 1) % m;  // first vertex of the a-run
      }
    }
    if (changes == 2) {
      lb = b_to_a;
      lf = a_to_b;
    }
  }
  if (lb == m || lb == lf) {
    // Geometric fallback: the lower vertices nearest the directions +/- tangent x (cb - ca)
    // as seen from the crotch.
    const glm::dvec3 crotch = 0.5 * (pos[a[ia]] + pos[b[ib]]);
    glm::dvec3 across = glm::cross(tangent, cb - ca);
    if (glm::length(across) < 1e-300) across = any_perpendicular(tangent);
    across = glm::normalize(across);
    double best_b = -2, best_f = -2;
    for (std::size_t k = 0; k < m; ++k) {
      glm::dvec3 d = pos[lower[k]] - crotch;
      d -= tangent * glm::dot(d, tangent);
      const double len = glm::length(d);
      if (len <= 0) continue;
      const double c = glm::dot(d, across) / len;
      if (c > best_b) {
        best_b = c;
        lb = k;
      }
      if (-c > best_f) {
        best_f = -c;
        lf = k;
      }
    }
    if (lb == lf) lf = (lb + m / 2) % m;
  }
  std::vector<std::uint32_t> chain_a, chain_b, loop_a, loop_b;
  for (std::size_t k = lb;; k = (k + 1) % m) {
    chain_a.push_back(lower[k]);
    if (k == lf) break;
  }
  for (std::size_t k = lf;; k = (k + 1) % m) {
    chain_b.push_back(lower[k]);
    if (k == lb) break;
  }
  for (std::size_t k = 0; k <= a.size(); ++k) loop_a.push_back(a[(ia + k) % a.size()]);
  for (std::size_t k = 0; k <= b.size(); ++k) loop_b.push_back(b[(ib + k) % b.size()]);
  stitch_open(chain_a, loop_a, pos, out);
  out.push_back({lower[lf], b[ib], a[ia]});
  stitch_open(chain_b, loop_b, pos, out);
  out.push_back({lower[lb], a[ia], b[ib]});
}

/// Branch fusion with k >= 3 upper loops: a junction whose child tube is a single loop that
/// ends in another junction straight away (forks a fraction of a slice apart: whorls, stems
/// of a binarized n-way fork that never came apart) is meshed as one junction, skipping the
/// loop between them, whose binary crotches would otherwise overlap.
///
/// The generalisation of fuse_chains. Each lower vertex belongs to one upper loop: the one
/// its strand is on (`label`, -1 when none is), else its predecessor's, else the nearest (by
/// the distance to the circle of the loop's mean radius around its centroid, in the lower
/// loop's plane). The lower loop is then made k runs, one per upper loop, which orders the
/// upper loops around it: a loop with several runs keeps its longest (a main stem reaching
/// the boundary between laterals around it), and a loop with none (a bundle inside) gets
/// the two vertices at the change of runs nearest to it in angle. Chain i runs from the last vertex of run i-1 to the
/// last vertex of run i and is stitched to loop i opened at its crotch vertex c_i (its vertex nearest the centroid of
/// the other upper loops); the crotch triangle (cut_i, c_{i+1}, c_i) closes the gap between neighbouring strips, and a
/// fan over c_1 .. c_k closes the hole the crotch edges leave in the middle (for k = 2 the two crotch triangles meet:
/// fuse_chains). Every edge is used exactly twice.
///
/// Returns false (and emits nothing) when the lower loop cannot be made k runs; the caller
/// then meshes the binary junctions one by one.
bool fuse_many(const std::vector<std::uint32_t>& lower, const std::vector<std::vector<std::uint32_t>>& uppers,
               const std::vector<int>& label, const std::vector<glm::dvec3>& pos, const Frame& frame,
               std::vector<Mesh::Triangle>& out) {
  const std::size_t k = uppers.size(), m = lower.size();
  if (k < 3 || m < k || label.size() != m) return false;
  std::vector<glm::dvec3> cu(k);
  std::vector<double> radius(k, 0.0);
  glm::dvec3 cl(0);
  for (auto v : lower) cl += pos[v];
  cl /= double(m);
  for (std::size_t i = 0; i < k; ++i) {
    glm::dvec3 c(0);
    for (auto v : uppers[i]) c += pos[v];
    cu[i] = c / double(uppers[i].size());
    for (auto v : uppers[i]) radius[i] += glm::length(frame.to_local(pos[v] - cu[i]));
    radius[i] /= double(uppers[i].size());
  }
  // The strands' labels, a vertex without one taking its predecessor's (as fuse_chains does),
  // else the nearest loop.
  std::vector<int> lab = label;
  int last = -1;
  for (std::size_t pass = 0; pass < 2; ++pass) {
    for (std::size_t v = 0; v < m; ++v) {
      if (label[v] >= 0) last = label[v];
      if (lab[v] < 0) lab[v] = last;
    }
  }
  auto angle = [&](const glm::dvec3& p) {
    const dvec2 q = frame.to_local(p - cl);
    return std::atan2(q.y, q.x);
  };
  for (std::size_t v = 0; v < m; ++v) {
    if (lab[v] >= 0) continue;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < k; ++i) {
      const double d = glm::length(frame.to_local(pos[lower[v]] - cu[i])) - radius[i];
      if (d < best) {
        best = d;
        lab[v] = static_cast<int>(i);
      }
    }
  }
  // Repairs towards one run per loop. A loop with several runs (a main stem whose strands reach
  // the boundary between the laterals around it) keeps its longest; the others go half to
  // each neighbouring run.
  struct Run {
    std::size_t start, length;
    int label;
  };
  auto cyclic_runs = [&] {
    std::vector<Run> r;
    std::size_t first = m;
    for (std::size_t v = 0; v < m && first == m; ++v) {
      if (lab[v] != lab[(v + m - 1) % m]) first = v;
    }
    if (first == m) return r;
    for (std::size_t n = 0; n < m; ++n) {
      const std::size_t v = (first + n) % m;
      if (r.empty() || lab[v] != r.back().label) {
        r.push_back({v, 1, lab[v]});
      } else {
        ++r.back().length;
      }
    }
    return r;
  };
  for (std::size_t guard = 0; guard < m; ++guard) {
    const std::vector<Run> r = cyclic_runs();
    if (r.size() < 2) return false;
    // The shortest run of a label with several (never the only longest one of its label).
    std::vector<std::size_t> count(k, 0);
    for (const Run& x : r) ++count[static_cast<std::size_t>(x.label)];
    std::size_t pick = r.size();
    for (std::size_t i = 0; i < r.size(); ++i) {
      if (count[static_cast<std::size_t>(r[i].label)] > 1 && (pick == r.size() || r[i].length < r[pick].length))
        pick = i;
    }
    if (pick == r.size()) break;
    const Run& x = r[pick];
    const int before = r[(pick + r.size() - 1) % r.size()].label, after = r[(pick + 1) % r.size()].label;
    for (std::size_t n = 0; n < x.length; ++n) lab[(x.start + n) % m] = 2 * n < x.length ? before : after;
  }
  // A loop without a run (a bundle inside the lower loop, its strands all off the boundary)
  // takes the two vertices around the change of runs nearest to it in angle.
  for (std::size_t i = 0; i < k; ++i) {
    const std::vector<Run> r = cyclic_runs();
    if (std::any_of(r.begin(), r.end(), [&](const Run& x) { return x.label == static_cast<int>(i); })) continue;
    const double a = angle(cu[i]);
    std::size_t best = r.size();
    double best_d = std::numeric_limits<double>::infinity();
    for (std::size_t q = 0; q < r.size(); ++q) {
      const std::size_t v = r[q].start, u = (v + m - 1) % m;
      const double d = std::abs(wrap_pi(angle(0.5 * (pos[lower[u]] + pos[lower[v]])) - a));
      if (r[q].length >= 2 && r[(q + r.size() - 1) % r.size()].length >= 2 && d < best_d) {
        best_d = d;
        best = q;
      }
    }
    if (best == r.size()) return false;
    lab[r[best].start] = lab[(r[best].start + m - 1) % m] = static_cast<int>(i);
  }
  const std::vector<Run> r = cyclic_runs();
  if (r.size() != k) return false;
  std::vector<std::size_t> run_end(k);
  std::vector<int> run_label(k);
  std::vector<std::uint8_t> seen(k, 0);
  for (std::size_t i = 0; i < k; ++i) {
    if (seen[static_cast<std::size_t>(r[i].label)]++) return false;
    run_end[i] = (r[i].start + r[i].length - 1) % m;
    run_label[i] = r[i].label;
  }

  std::vector<std::uint32_t> crotch(k);
  for (std::size_t i = 0; i < k; ++i) {
    const auto& u = uppers[static_cast<std::size_t>(run_label[i])];
    glm::dvec3 others(0);
    for (std::size_t x = 0; x < k; ++x) {
      if (x != static_cast<std::size_t>(run_label[i])) others += cu[x];
    }
    others /= double(k - 1);
    double best = std::numeric_limits<double>::infinity();
    for (auto v : u) {
      const double d = glm::dot(pos[v] - others, pos[v] - others);
      if (d < best) {
        best = d;
        crotch[i] = v;
      }
    }
  }
  for (std::size_t i = 0; i < k; ++i) {
    std::vector<std::uint32_t> chain, loop;
    for (std::size_t v = run_end[(i + k - 1) % k];; v = (v + 1) % m) {
      chain.push_back(lower[v]);
      if (v == run_end[i]) break;
    }
    const auto& u = uppers[static_cast<std::size_t>(run_label[i])];
    const std::size_t start = static_cast<std::size_t>(std::find(u.begin(), u.end(), crotch[i]) - u.begin());
    for (std::size_t j = 0; j <= u.size(); ++j) loop.push_back(u[(start + j) % u.size()]);
    stitch_open(chain, loop, pos, out);
    out.push_back({lower[run_end[i]], crotch[(i + 1) % k], crotch[i]});
  }
  for (std::size_t i = 1; i + 1 < k; ++i) out.push_back({crotch[0], crotch[i], crotch[i + 1]});
  return true;
}

class Builder {
 public:
  Builder(const Skeleton& s, const ContourSet& c, const MeshParams& p) : s_(s), c_(c), p_(p) {}
  StitchedMesh run(const ProgressFn& progress);

 private:
  std::vector<std::uint32_t> loop_ids(std::uint32_t l) const {
    std::vector<std::uint32_t> ids(c_.loop_size(l));
    for (std::uint32_t k = 0; k < ids.size(); ++k) ids[k] = c_.loop_begin[l] + k;
    return ids;
  }
  glm::dvec3 loop_centroid(std::uint32_t l) const {
    glm::dvec3 c(0);
    for (std::uint32_t v = c_.loop_begin[l]; v < c_.loop_begin[l + 1]; ++v) c += c_.point[v];
    return c / double(c_.loop_size(l));
  }
  /// Rotates `ids` so that it starts at the vertex carrying a strand that `other` also
  /// carries (the one nearest other's start), or at the vertex closest to other[0].
  void align(std::vector<std::uint32_t>& upper, const std::vector<std::uint32_t>& lower) const;

  /// Triangles of a range of tubes, in tube order (each range is built on its own thread and
  /// the ranges are concatenated in order, so the mesh does not depend on the thread count).
  struct Part {
    std::vector<Mesh::Triangle> triangles;
    std::vector<std::uint32_t> branch;
    std::vector<TriangleKind> kind;
    std::vector<Mesh::Triangle> scratch;
    void emit(std::uint32_t b, TriangleKind k) {
      triangles.insert(triangles.end(), scratch.begin(), scratch.end());
      branch.insert(branch.end(), scratch.size(), b);
      kind.insert(kind.end(), scratch.size(), k);
    }
  };

  void strip(std::uint32_t lower_loop, std::uint32_t upper_loop, std::uint32_t branch, Part& out) const;
  void fuse(const Junction& j, std::uint32_t branch, Part& out) const;
  /// The cap's ring and apex are the vertices first .. first + loop size (allocated by run()).
  void tip_cap(std::uint32_t loop, std::uint32_t branch, std::uint32_t first, Part& out);
  void root_cap(std::uint32_t loop, std::uint32_t branch, std::uint32_t centre, Part& out);
  void set_vertex(std::uint32_t i, const glm::dvec3& p, NodeId node, double u, double v, double period,
                  bool pole = false) {
    vertex_pole_[i] = pole;
    mesh_.positions[i] = p;
    mesh_.vertex_strand[i] = StrandId{};
    mesh_.vertex_node[i] = node;
    vertex_u_[i] = u;
    vertex_v_[i] = v;
    vertex_period_[i] = period;
  }
  void compute_uvs();
  /// A point on a loop's polygon: its arc length from the loop's first vertex, its distance
  /// from the point asked about, and where it is.
  struct LoopPoint {
    std::uint32_t vertex;  // the point is on the edge from this vertex to the next
    double t, arc, distance;
  };
  /// With `side` (#loop l's vertices), only edges whose ends are labelled `only` or 2 (a
  /// junction's lower_side), unless there are none.
  /// Only the `count` edges from the loop's vertex `from` on (its index in the loop), if given.
  LoopPoint nearest_on_loop(std::uint32_t l, const glm::dvec3& q, const std::uint8_t* side = nullptr,
                            std::uint8_t only = 0, std::uint32_t from = 0, std::uint32_t count = UINT32_MAX) const;
  /// Puts loop l's seam at arc length `arc` (taken modulo the perimeter).
  void set_seam(std::uint32_t l, double arc);
  /// The UVs of loop l's vertices, continuing those of loop `prev` (the one below it). For the
  /// first loop of a child tube, `side` labels prev's vertices (Junction::lower_side) and
  /// `only` is the child's label: its strands come from that side of the parent.
  void continue_uvs(std::uint32_t prev, std::uint32_t l, const std::uint8_t* side = nullptr, std::uint8_t only = 0);

  const Skeleton& s_;
  const ContourSet& c_;
  const MeshParams& p_;
  Mesh mesh_;
  MeshStats stats_;
  std::vector<double> loop_v_;               // per loop
  std::vector<double> vertex_u_, vertex_v_;  // per vertex
  std::vector<double> vertex_period_;        // per vertex: u once around its loop (MeshParams::uv_metres)
  std::vector<std::uint8_t> vertex_pole_;    // per vertex: a cap's apex or centre
  std::vector<double> vertex_angle_;         // per loop vertex: angle around its loop's centroid
  std::vector<double> vertex_arc_;           // per loop vertex: arc length from its loop's first vertex (metres)
  // Per loop: perimeter (metres), seam (arc length), u at the seam and per metre, u of one turn.
  std::vector<double> loop_perimeter_, loop_seam_, loop_u0_, loop_scale_, loop_period_;
  std::vector<glm::dvec3> loop_seam_point_;  // per loop: where its seam is
  std::uint32_t strand_count_ = 0;           // strand ids are below this
  /// continue_uvs' working arrays, one set per thread.
  struct UvScratch {
    struct Match {
      double u, v, rel, distance, weight;
      bool central;
    };
    std::vector<Match> match;
    std::vector<double> dist;
    std::vector<std::uint32_t> on, slot;  // slot: per strand, its vertex on the loop below (or none)
    std::vector<std::pair<double, double>> proposal;
  };
  tbb::enumerable_thread_specific<UvScratch> uv_scratch_;
  /// Per junction: the triangles of its k-way fusion when stacked junctions above it were
  /// merged into it (plan_stacked_junctions), else empty.
  std::vector<std::vector<Mesh::Triangle>> merged_fusion_;
  std::vector<std::uint8_t> folded_;  ///< per junction: meshed as part of a junction below it
  void plan_stacked_junctions();
  /// Puts every vertex on the float grid (core/mesh.h float_grid; MeshResult::grid).
  void snap_to_float_grid();
  double grid_ = 0;
  std::vector<TriangleKind> kind_;
};

void Builder::align(std::vector<std::uint32_t>& upper, const std::vector<std::uint32_t>& lower) const {
  const StrandId s0 = c_.strand[lower[0]];
  std::size_t best = 0;
  double best_d = std::numeric_limits<double>::infinity();
  bool shared = false;
  for (std::size_t k = 0; k < upper.size(); ++k) {
    const double d = glm::length(c_.point[upper[k]] - c_.point[lower[0]]);
    const bool same = s0.valid() && c_.strand[upper[k]] == s0;
    if ((same && !shared) || (same == shared && d < best_d)) {
      best = k;
      best_d = d;
      shared = shared || same;
    }
  }
  std::rotate(upper.begin(), upper.begin() + static_cast<std::ptrdiff_t>(best), upper.end());
}

void Builder::strip(std::uint32_t lower_loop, std::uint32_t upper_loop, std::uint32_t branch, Part& out) const {
  const auto lower = loop_ids(lower_loop);
  auto upper = loop_ids(upper_loop);
  align(upper, lower);
  // Angles of each loop's vertices in its own slice plane, around its own centroid (computed
  // once per vertex in compute_uvs): the two loops may be far apart along a thin branch and
  // their planes tilted against each other, so projecting one onto the other's plane would
  // scramble the angles. Frames are parallel-transported, so their normals share the origin.
  const double ref = vertex_angle_[lower[0]];
  // Without one turn on either loop the angles mean nothing: the greedy rule alone.
  AngleGuard guard;
  const bool g1 = unwrapped_angles(lower, vertex_angle_, ref, guard.lower);
  const bool g2 = unwrapped_angles(upper, vertex_angle_, ref, guard.upper);
  const bool guarded = g1 && g2;
  guard.tolerance = 0.25 * kTwoPi / double(std::max(lower.size(), upper.size()));
  out.scratch.clear();
  stitch(lower, upper, c_.point, out.scratch, guarded ? &guard : nullptr);
  out.emit(branch, TriangleKind::strip);
}

void Builder::plan_stacked_junctions() {
  const std::size_t nj = c_.junctions.size();
  merged_fusion_.assign(nj, {});
  folded_.assign(nj, 0);
  if (!p_.merge_stacked_junctions) return;
  std::vector<std::vector<std::uint32_t>> uppers;
  std::vector<std::uint32_t> merged;
  for (std::uint32_t ji = 0; ji < nj; ++ji) {
    if (folded_[ji]) continue;
    const Junction& j = c_.junctions[ji];
    uppers.clear();
    merged.clear();
    // Depth first: an upper tube that is one loop ending in a junction is replaced by that
    // junction's upper tubes.
    std::vector<std::pair<std::uint32_t, std::uint32_t>> stack{{j.upper_tubes[1], j.upper[1]},
                                                               {j.upper_tubes[0], j.upper[0]}};
    while (!stack.empty()) {
      const auto [ti, first] = stack.back();
      stack.pop_back();
      const Tube& t = c_.tubes[ti];
      if (t.loops.size() == 1 && t.end_junction != UINT32_MAX) {
        const Junction& up = c_.junctions[t.end_junction];
        merged.push_back(t.end_junction);
        stack.emplace_back(up.upper_tubes[1], up.upper[1]);
        stack.emplace_back(up.upper_tubes[0], up.upper[0]);
      } else {
        uppers.push_back(loop_ids(first));
      }
    }
    if (merged.empty()) continue;
    // Twigs of the fewest strands stay binary: merged, their crotches were measured to
    // intersect more, not less (on mtg_agraf, stems with a row of 5-strand twigs).
    if (std::any_of(uppers.begin(), uppers.end(), [](const auto& u) { return u.size() < kMinMergedLoop; })) continue;
    // Label the lower vertices by the upper loop carrying their strand.
    const std::vector<std::uint32_t> lower = loop_ids(j.lower);
    std::vector<int> label(lower.size(), -1);
    for (std::size_t i = 0; i < uppers.size(); ++i) {
      for (const std::uint32_t v : uppers[i]) {
        const StrandId st = c_.strand[v];
        if (!st.valid()) continue;
        for (std::size_t x = 0; x < lower.size(); ++x) {
          if (c_.strand[lower[x]] == st) label[x] = static_cast<int>(i);
        }
      }
    }
    std::vector<Mesh::Triangle> tris;
    if (!fuse_many(lower, uppers, label, c_.point, c_.loop_frame[j.lower], tris)) continue;
    merged_fusion_[ji] = std::move(tris);
    for (const std::uint32_t x : merged) {
      folded_[x] = 1;
      merged_fusion_[x].clear();  // (planned before this one, when junctions are not in tree order)
    }
  }
  stats_.merged_junctions = static_cast<std::size_t>(std::count(folded_.begin(), folded_.end(), 1));
}

void Builder::snap_to_float_grid() {
  if (mesh_.positions.empty()) return;
  using Bounds = std::pair<glm::dvec3, glm::dvec3>;
  const Bounds empty{glm::dvec3(std::numeric_limits<double>::infinity()),
                     glm::dvec3(-std::numeric_limits<double>::infinity())};
  auto join = [](const Bounds& a, const Bounds& b) {
    return Bounds{glm::min(a.first, b.first), glm::max(a.second, b.second)};
  };
  // (Minima and maxima: the same for any split.)
  const auto [lo, hi] = tbb::parallel_reduce(
      tbb::blocked_range<std::size_t>(0, mesh_.positions.size(), 1 << 16), empty,
      [&](const tbb::blocked_range<std::size_t>& r, Bounds b) {
        for (std::size_t v = r.begin(); v != r.end(); ++v) b = join(b, {mesh_.positions[v], mesh_.positions[v]});
        return b;
      },
      join);
  const glm::dvec3 half = 0.5 * (hi - lo);
  grid_ = float_grid(2.0 * std::max({half.x, half.y, half.z}));
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, mesh_.positions.size(), 1 << 14),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t v = r.begin(); v < r.end(); ++v)
                        mesh_.positions[v] = snap_to_grid(mesh_.positions[v], grid_);
                    });
}

void Builder::fuse(const Junction& j, std::uint32_t branch, Part& out) const {
  out.scratch.clear();
  fuse_chains(loop_ids(j.lower), loop_ids(j.upper[0]), loop_ids(j.upper[1]), j.lower_side, c_.point,
              c_.loop_frame[j.lower].tangent, out.scratch);
  out.emit(branch, TriangleKind::fusion);
}

void Builder::tip_cap(std::uint32_t loop, std::uint32_t branch, std::uint32_t first, Part& out) {
  const auto ids = loop_ids(loop);
  const glm::dvec3 c = loop_centroid(loop);
  const glm::dvec3 t = c_.loop_frame[loop].tangent;
  double r = 0;
  for (auto v : ids) r += glm::length(c_.point[v] - c);
  r /= double(ids.size());
  const double h = p_.tip_dome * r;
  const NodeId node = c_.loop_node[loop];
  const double v0 = loop_v_[loop];
  const double dv = p_.uv_metres > 0 ? 1.0 / p_.uv_metres : p_.uv_repeat_u / (kTwoPi * std::max(r, 1e-12));
  // One intermediate ring on the sphere (37 degrees up), then the apex.
  std::vector<std::uint32_t> ring(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k) {
    ring[k] = first + static_cast<std::uint32_t>(k);
    set_vertex(ring[k], c + 0.8 * (c_.point[ids[k]] - c) + 0.6 * h * t, node, vertex_u_[ids[k]],
               vertex_v_[ids[k]] + 0.6 * h * dv, vertex_period_[ids[k]]);
  }
  const std::uint32_t apex = first + static_cast<std::uint32_t>(ids.size());
  set_vertex(apex, c + h * t, node, loop_u0_[loop] + 0.5 * loop_period_[loop], v0 + h * dv, loop_period_[loop],
             true);
  out.scratch.clear();
  for (std::size_t k = 0; k < ids.size(); ++k) {
    const std::size_t k1 = (k + 1) % ids.size();
    out.scratch.push_back({ids[k], ids[k1], ring[k]});
    out.scratch.push_back({ids[k1], ring[k1], ring[k]});
    out.scratch.push_back({ring[k], ring[k1], apex});
  }
  out.emit(branch, TriangleKind::tip_cap);
}

void Builder::root_cap(std::uint32_t loop, std::uint32_t branch, std::uint32_t centre, Part& out) {
  const auto ids = loop_ids(loop);
  // Base: the centre below the loop's plane.
  const Frame& f = c_.loop_frame[loop];
  glm::dvec3 c = loop_centroid(loop);
  c -= f.tangent * glm::dot(c - c_.loop_center[loop], f.tangent);
  // A very shallow dome downwards (5% of the radius), so the root node lies strictly inside
  // the mesh rather than exactly on its base, where float32 export could put it either side.
  c -= f.tangent * (0.05 * c_.loop_radius[loop]);
  // v: the distance from the rim (a polar mapping; the rim's own v is constant).
  const double r = c_.loop_radius[loop];
  const double below = p_.uv_metres > 0 ? r / p_.uv_metres : p_.uv_repeat_u / kTwoPi;
  set_vertex(centre, c, c_.loop_node[loop], loop_u0_[loop] + 0.5 * loop_period_[loop], loop_v_[loop] - below,
             loop_period_[loop], true);
  out.scratch.clear();
  for (std::size_t k = 0; k < ids.size(); ++k) out.scratch.push_back({ids[(k + 1) % ids.size()], ids[k], centre});
  out.emit(branch, TriangleKind::root_cap);
}

Builder::LoopPoint Builder::nearest_on_loop(std::uint32_t l, const glm::dvec3& q, const std::uint8_t* side,
                                             std::uint8_t only, std::uint32_t from, std::uint32_t count) const {
  LoopPoint best{c_.loop_begin[l], 0.0, 0.0, std::numeric_limits<double>::infinity()};
  const std::uint32_t b = c_.loop_begin[l], e = c_.loop_begin[l + 1], n = e - b;
  count = std::min(count, n);
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::uint32_t v = b + (from + i) % n, w = v + 1 < e ? v + 1 : b;
    if (side && ((side[v - b] != only && side[v - b] != 2) || (side[w - b] != only && side[w - b] != 2))) continue;
    const glm::dvec3& p0 = c_.point[v];
    const glm::dvec3 d = c_.point[w] - p0;
    const double len2 = glm::dot(d, d);
    const double t = len2 > 0 ? std::clamp(glm::dot(q - p0, d) / len2, 0.0, 1.0) : 0.0;
    const double dist = glm::length(q - (p0 + t * d));
    const double arc_w = w == b ? loop_perimeter_[l] : vertex_arc_[w];
    if (dist < best.distance) best = {v, t, vertex_arc_[v] + t * (arc_w - vertex_arc_[v]), dist};
  }
  if (!std::isfinite(best.distance) && (side || count < n)) return nearest_on_loop(l, q);
  return best;
}

void Builder::set_seam(std::uint32_t l, double arc) {
  const double p = loop_perimeter_[l];
  arc = std::fmod(arc, p);
  if (arc < 0) arc += p;
  loop_seam_[l] = arc;
  const std::uint32_t b = c_.loop_begin[l], e = c_.loop_begin[l + 1];
  std::uint32_t v = b;
  while (v + 1 < e && vertex_arc_[v + 1] <= arc) ++v;
  const glm::dvec3 p0 = c_.point[v], p1 = c_.point[v + 1 < e ? v + 1 : b];
  const double span = (v + 1 < e ? vertex_arc_[v + 1] : p) - vertex_arc_[v];
  loop_seam_point_[l] = span > 0 ? p0 + (p1 - p0) * std::clamp((arc - vertex_arc_[v]) / span, 0.0, 1.0) : p0;
}

void Builder::continue_uvs(std::uint32_t prev, std::uint32_t l, const std::uint8_t* side, std::uint8_t only) {
  const bool metres = p_.uv_metres > 0;
  const std::uint32_t b = c_.loop_begin[l], e = c_.loop_begin[l + 1], m = e - b;
  const double pl = loop_perimeter_[l], pp = loop_perimeter_[prev];
  const double turn = metres ? pl / p_.uv_metres : p_.uv_repeat_u;  // u once around
  const double scale = turn / pl;
  const double qp = loop_period_[prev];
  const double v_scale =
      metres ? 1.0 / p_.uv_metres
             : p_.uv_repeat_u / (kTwoPi * std::max(0.5 * (c_.loop_radius[prev] + c_.loop_radius[l]), 1e-12));

  // Each vertex takes u and v where its strand was on the loop below (v plus the distance to
  // it, so v runs along the strands), or where the nearest point of the loop below has them.
  UvScratch& scratch = uv_scratch_.local();
  std::vector<UvScratch::Match>& match = scratch.match;
  std::vector<double>& dist = scratch.dist;
  match.resize(m);
  dist.resize(m);
  const std::uint32_t pb = c_.loop_begin[prev], pe = c_.loop_begin[prev + 1], n_prev = pe - pb;
  // The vertex of prev on each strand (a per-thread table over all strands, emptied after).
  std::vector<std::uint32_t>& slot = scratch.slot;
  if (slot.size() < strand_count_) slot.assign(strand_count_, UINT32_MAX);
  for (std::uint32_t v = pb; v < pe; ++v) {
    const StrandId st = c_.strand[v];
    if (st.valid() && (!side || side[v - pb] == only || side[v - pb] == 2)) slot[st.value] = v;
  }
  std::vector<std::uint32_t>& on = scratch.on;  // per vertex of l: its strand's vertex on prev
  on.assign(m, UINT32_MAX);
  std::uint32_t matched = 0;
  for (std::uint32_t k = 0; k < m; ++k) {
    const StrandId st = c_.strand[b + k];
    if (st.valid()) on[k] = slot[st.value];
    matched += on[k] != UINT32_MAX;
  }
  for (std::uint32_t v = pb; v < pe; ++v) {
    if (c_.strand[v].valid()) slot[c_.strand[v].value] = UINT32_MAX;
  }
  for (std::uint32_t k = 0; k < m; ++k) {
    const std::uint32_t v = b + k;
    LoopPoint n{};
    if (on[k] != UINT32_MAX) {
      n = {on[k], 0.0, vertex_arc_[on[k]], glm::length(c_.point[v] - c_.point[on[k]])};
    } else if (matched > 0) {
      // Between where the strands of its matched neighbours are on prev (loops keep their order).
      std::uint32_t k0 = (k + m - 1) % m, k1 = (k + 1) % m;
      while (on[k0] == UINT32_MAX) k0 = (k0 + m - 1) % m;
      while (on[k1] == UINT32_MAX) k1 = (k1 + 1) % m;
      const std::uint32_t from = (on[k0] - pb + n_prev - 1) % n_prev;
      const std::uint32_t count = (on[k1] - on[k0] + n_prev) % n_prev + 2;
      n = nearest_on_loop(prev, c_.point[v], side, only, from, count);
    } else {
      n = nearest_on_loop(prev, c_.point[v], side, only);
    }
    double rel = vertex_arc_[v] - loop_seam_[l];
    if (rel < 0) rel += pl;
    double rel_prev = n.arc - loop_seam_[prev];
    if (rel_prev < 0) rel_prev += pp;
    if (rel_prev >= pp) rel_prev -= pp;
    const std::uint32_t next = n.vertex + 1 < pe ? n.vertex + 1 : pb;
    double u1 = vertex_u_[next];
    u1 += qp * std::round((vertex_u_[n.vertex] - u1) / qp);  // across the seam: the same side
    match[k] = {vertex_u_[n.vertex] + n.t * (u1 - vertex_u_[n.vertex]),
                vertex_v_[n.vertex] + n.t * (vertex_v_[next] - vertex_v_[n.vertex]) + v_scale * n.distance,
                rel,
                n.distance,
                1.0,
                rel > 0.15 * pl && rel < 0.85 * pl && rel_prev > 0.15 * pp && rel_prev < 0.85 * pp};
    dist[k] = n.distance;
  }
  // Vertices much farther from the loop below than most (a child's crotch side, facing its
  // sibling) match nothing there: they weigh little.
  std::nth_element(dist.begin(), dist.begin() + m / 2, dist.end());
  const double h = 2.0 * std::max(dist[m / 2], 1e-300);
  for (UvScratch::Match& x : match) x.weight = x.distance <= h ? 1.0 : (h / x.distance) * (h / x.distance);

  // u: the loop's arc length from its seam, plus the offset that continues the u of the loop
  // below. Each vertex proposes one (what makes its own u equal to what it took); proposals
  // across either loop's seam are a turn off, so those near the weighted median are averaged,
  // preferably of vertices away from the seams. (Carrying more of the loop below up the
  // branch, its differences from the loop's own arc length fading over a few radii, spread a
  // fork's shear wider but measured worse on the samples: docs/quality.md.)
  const bool any_central =
      std::count_if(match.begin(), match.end(), [](const UvScratch::Match& x) { return x.central; }) >= 3;
  std::vector<std::pair<double, double>>& proposal = scratch.proposal;  // (offset, weight)
  proposal.clear();
  for (const UvScratch::Match& x : match) {
    if (x.central || !any_central) proposal.emplace_back(x.u - scale * x.rel, x.weight);
  }
  std::sort(proposal.begin(), proposal.end());
  double total = 0;
  for (const auto& x : proposal) total += x.second;
  double median = proposal.front().first, acc = 0;
  for (const auto& x : proposal) {
    acc += x.second;
    if (acc >= 0.5 * total) {
      median = x.first;
      break;
    }
  }
  double sum = 0, wsum = 0;
  for (const auto& x : proposal) {
    double d = x.first - median;
    d -= qp * std::round(d / qp);
    if (std::abs(d) <= 0.25 * qp) {
      sum += (median + d) * x.second;
      wsum += x.second;
    }
  }
  // v: one value per loop (rings stay rings), the weighted mean of what its vertices took.
  double vsum = 0, vw = 0;
  for (const UvScratch::Match& x : match) {
    vsum += x.v * x.weight;
    vw += x.weight;
  }
  loop_u0_[l] = wsum > 0 ? sum / wsum : median;
  loop_v_[l] = vsum / vw;
  loop_period_[l] = turn;
  for (std::uint32_t k = 0; k < m; ++k) {
    vertex_u_[b + k] = loop_u0_[l] + scale * match[k].rel;
    vertex_v_[b + k] = loop_v_[l];
    vertex_period_[b + k] = turn;
  }
}

void Builder::compute_uvs() {
  const std::uint32_t nl = static_cast<std::uint32_t>(c_.loop_count());
  const double repeat = p_.uv_repeat_u;
  const bool metres = p_.uv_metres > 0;
  // Arc length of every vertex along its loop, and the loop's perimeter: in metres u is the
  // distance around the loop (over uv_metres); once around, the fraction of a turn.
  vertex_arc_.assign(c_.point.size(), 0.0);
  vertex_angle_.assign(c_.point.size(), 0.0);
  vertex_u_.assign(c_.point.size(), 0.0);
  vertex_v_.assign(c_.point.size(), 0.0);
  vertex_period_.assign(c_.point.size(), repeat);
  loop_perimeter_.assign(nl, 0.0);
  strand_count_ = 0;
  for (const StrandId st : c_.strand) {
    if (st.valid()) strand_count_ = std::max(strand_count_, st.value + 1);
  }
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, nl, 1024), [&](const tbb::blocked_range<std::uint32_t>& range) {
    for (std::uint32_t l = range.begin(); l != range.end(); ++l) {
      const std::uint32_t b = c_.loop_begin[l], e = c_.loop_begin[l + 1];
      double arc = 0;
      for (std::uint32_t v = b; v < e; ++v) {
        vertex_arc_[v] = arc;
        arc += glm::length(c_.point[v + 1 < e ? v + 1 : b] - c_.point[v]);
      }
      loop_perimeter_[l] = std::max(arc, 1e-300);
      // The angle around the loop's own centroid (the strips' guard, see strip()).
      const glm::dvec3 centre = loop_centroid(l);
      const Frame& f = c_.loop_frame[l];
      for (std::uint32_t v = b; v < e; ++v) {
        const dvec2 q = f.to_local(c_.point[v] - centre);
        vertex_angle_[v] = fast_atan2(q.y, q.x);  // (std::atan2: most of this pass)
      }
      // Once around, u is the turn's fraction by angle rather than by arc length (a fused loop,
      // wider on one side, is not stretched round), as far as the angles go round once.
      if (!metres && e - b >= 3) {
        double turned = 0, prev = vertex_angle_[b];
        bool monotone = true;
        for (std::uint32_t v = b + 1; v <= e; ++v) {
          const double a = vertex_angle_[v < e ? v : b];
          const double d = wrap_pi(a - prev);
          monotone = monotone && d > 0;
          turned += d;
          prev = a;
        }
        if (monotone && std::abs(turned - kTwoPi) < 1e-6) {
          double at = 0;
          for (std::uint32_t v = b; v < e; ++v) {
            vertex_arc_[v] = loop_perimeter_[l] * at / kTwoPi;
            at += wrap_pi(vertex_angle_[v + 1 < e ? v + 1 : b] - vertex_angle_[v]);
          }
        }
      }
    }
  });

  // Seams: one line per branch. Each loop's seam lies where the seam of the loop below it was
  // (the nearest point). At a junction the seam goes on into the child it is nearer to, and the
  // other child's seam starts at its crotch, facing its sibling, where the crotch triangles
  // join loops that share no strand anyway.
  loop_seam_.assign(nl, 0.0);
  loop_seam_point_.assign(nl, glm::dvec3(0));
  loop_u0_.assign(nl, 0.0);
  loop_v_.assign(nl, 0.0);
  loop_period_.assign(nl, repeat);
  // A tube needs the last loop of its parent's tube: tubes in waves by their depth in the tree
  // (parents first), each wave's tubes in parallel.
  const auto nt = static_cast<std::uint32_t>(c_.tubes.size());
  std::vector<std::uint32_t> depth(nt, UINT32_MAX), chain;
  std::uint32_t deepest = 0;
  for (std::uint32_t ti = 0; ti < nt; ++ti) {
    // Up to a tube of known depth (or the root), then down again.
    for (std::uint32_t x = ti; depth[x] == UINT32_MAX;) {
      chain.push_back(x);
      const std::uint32_t j = c_.tubes[x].start_junction;
      if (j == UINT32_MAX) break;
      x = c_.junctions[j].lower_tube;
    }
    while (!chain.empty()) {
      const std::uint32_t x = chain.back();
      chain.pop_back();
      const std::uint32_t j = c_.tubes[x].start_junction;
      depth[x] = j == UINT32_MAX ? 0 : depth[c_.junctions[j].lower_tube] + 1;
    }
    deepest = std::max(deepest, depth[ti]);
  }
  std::vector<std::uint32_t> wave_begin(deepest + 2, 0), order(c_.tubes.size());
  for (const std::uint32_t d : depth) ++wave_begin[d + 1];
  for (std::uint32_t d = 0; d <= deepest; ++d) wave_begin[d + 1] += wave_begin[d];
  {
    std::vector<std::uint32_t> at(wave_begin.begin(), wave_begin.end() - 1);
    for (std::uint32_t ti = 0; ti < c_.tubes.size(); ++ti) order[at[depth[ti]]++] = ti;
  }
  auto tube_uvs = [&](std::uint32_t ti) {
    const Tube& t = c_.tubes[ti];
    if (t.loops.empty()) return;
    std::uint32_t prev = UINT32_MAX;
    if (t.start_junction != UINT32_MAX) prev = c_.junctions[t.start_junction].lower;
    for (const std::uint32_t l : t.loops) {
      const std::uint32_t b = c_.loop_begin[l], e = c_.loop_begin[l + 1];
      if (prev == UINT32_MAX) {
        // The root: at the vertex farthest along the frame's normal.
        const glm::dvec3 centre = loop_centroid(l), n = c_.loop_frame[l].normal;
        std::uint32_t far = b;
        for (std::uint32_t v = b; v < e; ++v) {
          if (glm::dot(c_.point[v] - centre, n) > glm::dot(c_.point[far] - centre, n)) far = v;
        }
        set_seam(l, vertex_arc_[far]);
      } else if (l == t.loops.front()) {
        const Junction& j = c_.junctions[t.start_junction];
        const bool main = j.upper_tubes[0] == ti;
        const std::uint32_t sibling = j.upper[main ? 1 : 0];
        const glm::dvec3& seam = loop_seam_point_[prev];
        const LoopPoint mine = nearest_on_loop(l, seam), theirs = nearest_on_loop(sibling, seam);
        if (main ? mine.distance <= theirs.distance : mine.distance < theirs.distance) {
          set_seam(l, mine.arc);
        } else {
          const glm::dvec3 other = loop_centroid(sibling);
          std::uint32_t best = b;
          for (std::uint32_t v = b; v < e; ++v) {
            if (glm::length(c_.point[v] - other) < glm::length(c_.point[best] - other)) best = v;
          }
          set_seam(l, vertex_arc_[best]);
        }
      } else {
        set_seam(l, nearest_on_loop(l, loop_seam_point_[prev]).arc);
      }
      prev = l;
    }
    // The UVs, loop by loop.
    prev = t.start_junction != UINT32_MAX ? c_.junctions[t.start_junction].lower : UINT32_MAX;
    for (const std::uint32_t l : t.loops) {
      const std::uint32_t b = c_.loop_begin[l], e = c_.loop_begin[l + 1];
      if (prev == UINT32_MAX) {
        // The root: u = 0 opposite the seam, v = 0.
        loop_period_[l] = metres ? loop_perimeter_[l] / p_.uv_metres : repeat;
        loop_u0_[l] = -0.5 * loop_period_[l];
        for (std::uint32_t v = b; v < e; ++v) {
          double rel = vertex_arc_[v] - loop_seam_[l];
          if (rel < 0) rel += loop_perimeter_[l];
          vertex_u_[v] = loop_u0_[l] + loop_period_[l] * rel / loop_perimeter_[l];
          vertex_period_[v] = loop_period_[l];
        }
      } else if (l == t.loops.front() && t.start_junction != UINT32_MAX) {
        const Junction& j = c_.junctions[t.start_junction];
        const bool labelled = j.lower_side.size() == c_.loop_size(j.lower);
        continue_uvs(prev, l, labelled ? j.lower_side.data() : nullptr, j.upper_tubes[0] == ti ? 0 : 1);
      } else {
        continue_uvs(prev, l);
      }
      prev = l;
    }
  };
  for (std::uint32_t d = 0; d <= deepest; ++d) {
    tbb::parallel_for(tbb::blocked_range<std::uint32_t>(wave_begin[d], wave_begin[d + 1], 16),
                      [&](const tbb::blocked_range<std::uint32_t>& r) {
                        for (std::uint32_t i = r.begin(); i != r.end(); ++i) tube_uvs(order[i]);
                      });
  }
}

StitchedMesh Builder::run(const ProgressFn& progress) {
  Stopwatch clock;
  // Vertices added by the caps: a ring and an apex per tip, after the loop vertices in tube
  // order, then the root's base centre. Known up front, so tubes can be stitched in parallel
  // (and the vertex arrays are allocated once, at their final size).
  const std::size_t tubes = c_.tubes.size();
  const bool has_root = tubes > 0 && !c_.tubes[0].loops.empty();
  std::vector<std::uint32_t> cap_first(tubes + 1);
  std::size_t nv = c_.point.size();
  for (std::size_t ti = 0; ti < tubes; ++ti) {
    cap_first[ti] = static_cast<std::uint32_t>(nv);
    const Tube& t = c_.tubes[ti];
    if (t.end_junction == UINT32_MAX && !t.loops.empty()) nv += c_.loop_size(t.loops.back()) + 1;
  }
  cap_first[tubes] = static_cast<std::uint32_t>(nv);
  if (has_root) ++nv;
  mesh_.positions.reserve(nv);
  mesh_.positions.assign(c_.point.begin(), c_.point.end());
  mesh_.vertex_strand.reserve(nv);
  mesh_.vertex_strand.assign(c_.strand.begin(), c_.strand.end());
  mesh_.vertex_node.resize(nv);
  tbb::parallel_for(tbb::blocked_range<std::uint32_t>(0, c_.loop_count(), 4096),
                    [&](const tbb::blocked_range<std::uint32_t>& r) {
                      for (std::uint32_t l = r.begin(); l != r.end(); ++l) {
                        for (std::uint32_t v = c_.loop_begin[l]; v < c_.loop_begin[l + 1]; ++v)
                          mesh_.vertex_node[v] = c_.loop_node[l];
                      }
                    });
  vertex_u_.reserve(nv);
  vertex_v_.reserve(nv);
  vertex_period_.reserve(nv);
  vertex_pole_.assign(nv, 0);
  compute_uvs();
  mesh_.positions.resize(nv);
  mesh_.vertex_strand.resize(nv);
  vertex_u_.resize(nv);
  vertex_v_.resize(nv);
  vertex_period_.resize(nv);
  plan_stacked_junctions();
  stats_.timings.add("setup", clock.lap());

  // Fixed ranges of tubes (not the scheduler's), concatenated in order.
  constexpr std::size_t kTubesPerPart = 256;
  std::vector<Part> parts((tubes + kTubesPerPart - 1) / kTubesPerPart);
  std::size_t done = 0;
  std::mutex progress_mutex;
  tbb::parallel_for(std::size_t{0}, parts.size(), [&](std::size_t pi) {
    Part& part = parts[pi];
    // Room for the part's triangles (a strip has as many as its two loops' vertices, a tip
    // cap three per vertex, a fusion about one per vertex of its three loops), rather than
    // growing the arrays as they come.
    std::size_t expected = 0;
    for (std::size_t ti = pi * kTubesPerPart; ti < std::min(tubes, (pi + 1) * kTubesPerPart); ++ti) {
      const Tube& t = c_.tubes[ti];
      for (const std::uint32_t l : t.loops) expected += 2 * c_.loop_size(l);
      if (t.end_junction != UINT32_MAX) {
        for (const std::uint32_t l : c_.junctions[t.end_junction].upper) expected += c_.loop_size(l);
      } else if (!t.loops.empty()) {
        expected += 3 * c_.loop_size(t.loops.back());
      }
    }
    part.triangles.reserve(expected);
    part.branch.reserve(expected);
    part.kind.reserve(expected);
    for (std::size_t ti = pi * kTubesPerPart; ti < std::min(tubes, (pi + 1) * kTubesPerPart); ++ti) {
      const Tube& t = c_.tubes[ti];
      const std::uint32_t branch = t.branch.value;
      for (std::size_t k = 0; k + 1 < t.loops.size(); ++k) strip(t.loops[k], t.loops[k + 1], branch, part);
      if (t.end_junction != UINT32_MAX) {
        const std::uint32_t ji = t.end_junction;
        if (!merged_fusion_[ji].empty()) {
          part.scratch = merged_fusion_[ji];
          part.emit(branch, TriangleKind::fusion);
        } else if (!folded_[ji]) {
          fuse(c_.junctions[ji], branch, part);
        }
      } else if (!t.loops.empty()) {
        tip_cap(t.loops.back(), branch, cap_first[ti], part);
      }
    }
    if (progress) {
      const std::lock_guard lock(progress_mutex);
      progress("meshing", double(++done) / double(parts.size()));
    }
  });
  Part root;
  if (has_root) root_cap(c_.tubes[0].loops.front(), c_.tubes[0].branch.value, cap_first[tubes], root);
  // The parts in order, then the root's cap: each copied to its place by its own task (and
  // released by it), rather than appended one after another (large grown tree: a serial 11 ms).
  parts.push_back(std::move(root));
  std::vector<std::size_t> offset(parts.size() + 1, 0);
  for (std::size_t pi = 0; pi < parts.size(); ++pi) offset[pi + 1] = offset[pi] + parts[pi].triangles.size();
  const std::size_t nt = offset.back();
  mesh_.triangles.resize(nt);
  mesh_.triangle_branch.resize(nt);
  kind_.resize(nt);
  tbb::parallel_for(std::size_t{0}, parts.size(), [&](std::size_t pi) {
    Part& from = parts[pi];
    const auto at = static_cast<std::ptrdiff_t>(offset[pi]);
    std::copy(from.triangles.begin(), from.triangles.end(), mesh_.triangles.begin() + at);
    std::copy(from.branch.begin(), from.branch.end(), mesh_.triangle_branch.begin() + at);
    std::copy(from.kind.begin(), from.kind.end(), kind_.begin() + at);
    from = Part{};
  });
  snap_to_float_grid();
  for (const Tube& t : c_.tubes) {
    stats_.strips += t.loops.empty() ? 0 : t.loops.size() - 1;
    if (t.end_junction != UINT32_MAX) {
      ++stats_.junctions;
    } else if (!t.loops.empty()) {
      ++stats_.tip_caps;
    }
  }
  stats_.timings.add("stitching", clock.lap());
  return StitchedMesh{std::move(mesh_),          std::move(kind_),        std::move(vertex_u_), std::move(vertex_v_),
                      std::move(vertex_period_), std::move(vertex_pole_), std::move(stats_),   grid_};
}

/// Drops the triangles a repair left as (u, u, u): each hole takes the last live triangle
/// (they are few).
void drop_degenerate_triangles(StitchedMesh& s) {
  Mesh& m = s.mesh;
  const std::size_t kept = fill_holes(
      m.triangles.size(),
      [&](std::size_t f) {
        const auto& t = m.triangles[f];
        return t[0] != t[1] || t[1] != t[2];
      },
      [&](std::size_t from, std::size_t to) {
        m.triangles[to] = m.triangles[from];
        m.triangle_branch[to] = m.triangle_branch[from];
        s.triangle_kind[to] = s.triangle_kind[from];
      });
  m.triangles.resize(kept);
  m.triangle_branch.resize(kept);
  s.triangle_kind.resize(kept);
}

/// Removes the vertices no triangle uses, keeping the others in order but for the last ones.
void drop_unused_vertices(StitchedMesh& s) {
  // The unused vertices are few (merged junctions, a repair's collapses and refills: 60 of
  // 1.7 M on the large grown tree): each hole takes the last used vertex, and only the
  // triangles of the vertices so moved change (rather than renumbering every vertex).
  Mesh& m = s.mesh;
  const std::size_t nv = m.positions.size();
  std::vector<std::uint8_t> used(nv, 0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m.triangles.size(), 1 << 16),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t f = r.begin(); f != r.end(); ++f) {
                        for (const std::uint32_t v : m.triangles[f])
                          std::atomic_ref<std::uint8_t>(used[v]).store(1, std::memory_order_relaxed);
                      }
                    });
  std::vector<std::pair<std::uint32_t, std::uint32_t>> moves;  // (from, to)
  const std::size_t kept = fill_holes(
      nv, [&](std::size_t v) { return used[v] != 0; },
      [&](std::size_t from, std::size_t to) {
        m.positions[to] = m.positions[from];
        m.vertex_strand[to] = m.vertex_strand[from];
        m.vertex_node[to] = m.vertex_node[from];
        s.vertex_u[to] = s.vertex_u[from];
        s.vertex_v[to] = s.vertex_v[from];
        s.vertex_period[to] = s.vertex_period[from];
        s.vertex_pole[to] = s.vertex_pole[from];
        moves.emplace_back(static_cast<std::uint32_t>(from), static_cast<std::uint32_t>(to));
      });
  if (kept == nv) return;
  std::vector<std::uint32_t> moved_to(nv - kept, UINT32_MAX);  // for vertex kept + k: its new index
  for (const auto& [from, to] : moves) moved_to[from - kept] = to;
  m.positions.resize(kept);
  m.vertex_strand.resize(kept);
  m.vertex_node.resize(kept);
  s.vertex_u.resize(kept);
  s.vertex_v.resize(kept);
  s.vertex_period.resize(kept);
  s.vertex_pole.resize(kept);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m.triangles.size(), 1 << 16),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t f = r.begin(); f != r.end(); ++f) {
                        for (std::uint32_t& v : m.triangles[f]) {
                          if (v >= kept) v = moved_to[v - kept];
                        }
                      }
                    });
}

}  // namespace

void stitch_loops(const std::vector<std::uint32_t>& lower, const std::vector<std::uint32_t>& upper,
                  const std::vector<glm::dvec3>& positions, std::vector<Mesh::Triangle>& out) {
  SM_CHECK(!lower.empty() && !upper.empty(), "stitch_loops: empty loop");
  stitch(lower, upper, positions, out, nullptr);
}

void fuse_loops(const std::vector<std::uint32_t>& lower, const std::vector<std::uint32_t>& upper_main,
                const std::vector<std::uint32_t>& upper_lateral, const std::vector<glm::dvec3>& positions,
                const glm::dvec3& tangent, std::vector<Mesh::Triangle>& out) {
  SM_CHECK(lower.size() >= 3 && upper_main.size() >= 3 && upper_lateral.size() >= 3,
           "fuse_loops: loops need 3 vertices");
  fuse_chains(lower, upper_main, upper_lateral, {}, positions, tangent, out);
}

void validate_params(const MeshParams& p) { check_params(p); }

StitchedMesh stitch_mesh(const Skeleton& skeleton, const ContourSet& contours, const MeshParams& params,
                         const ProgressFn& progress) {
  validate_params(params);
  Builder b(skeleton, contours, params);
  return b.run(progress);
}

MeshResult finish_mesh(StitchedMesh s, const MeshParams& params) {
  validate_params(params);
  Stopwatch clock;
  MeshStats stats = std::move(s.stats);
  drop_degenerate_triangles(s);
  drop_unused_vertices(s);
  Mesh& m = s.mesh;
  // The corners around each vertex, for the normals and the topology check.
  const VertexCorners corners = vertex_corners(m);
  if (params.normals) m.normals = angle_weighted_normals(m, corners);
  if (params.uvs) {
    m.corner_uvs.resize(m.triangles.size());
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, m.triangles.size(), 8192),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t f = range.begin(); f != range.end(); ++f) {
                          const auto& t = m.triangles[f];
                          double u[3], v[3], period[3];
                          for (int k = 0; k < 3; ++k) {
                            u[k] = s.vertex_u[t[std::size_t(k)]];
                            v[k] = s.vertex_v[t[std::size_t(k)]];
                            period[k] = s.vertex_period[t[std::size_t(k)]];
                          }
                          // Seams: each u is known up to whole turns of its own loop; a triangle
                          // takes the turns nearest to its largest u (across a seam that lifts
                          // the small side by one turn; in metres loops of different sizes have
                          // turns of different lengths). A cap's pole is never that u: it lies
                          // half a turn from the seam.
                          int top = -1;
                          for (int k = 0; k < 3; ++k) {
                            if (!s.vertex_pole[t[std::size_t(k)]] && (top < 0 || u[k] > u[top])) top = k;
                          }
                          if (top < 0) top = 0;
                          for (int k = 0; k < 3; ++k) {
                            if (k != top && period[k] > 0) u[k] += period[k] * std::round((u[top] - u[k]) / period[k]);
                          }
                          for (int k = 0; k < 3; ++k)
                            m.corner_uvs[f][std::size_t(k)] = glm::vec2(float(u[k]), float(v[k]));
                        }
                      });
  }
  stats.timings.add("normals_uvs", clock.lap());
  stats.bad_edges = unpaired_half_edges(m, corners);
  if (stats.bad_edges > 0) {
    stats.warnings.add_count("bad_edges",
                             "half-edges without exactly one opposite twin (mesh not closed or not manifold)",
                             stats.bad_edges);
  }
  stats.timings.add("check", clock.lap());
  stats.vertices = m.positions.size();
  stats.triangles = m.triangles.size();
  return MeshResult{std::move(m), std::move(s.triangle_kind), std::move(stats), s.grid};
}

MeshResult build_mesh(const Skeleton& skeleton, const ContourSet& contours, const MeshParams& params,
                      const ProgressFn& progress) {
  return finish_mesh(stitch_mesh(skeleton, contours, params, progress), params);
}

}  // namespace sm
