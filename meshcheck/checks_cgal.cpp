// The CGAL part of the mesh checks: self-intersections and point-in-mesh, and the exact
// intersection tests and hole filling of intersections.h. CGAL is slow to compile: checks.cpp
// calls this through checks_cgal.h.
//
// Self-intersections use CGAL Polygon Mesh Processing's `self_intersections` on a Surface_mesh
// whenever the triangles form a valid polygon mesh, which is the normal case for our output.
// CGAL 5.5 has no triangle-soup variant, so broken inputs (non-manifold, misoriented) go
// through the same box-intersection filter and the same exact tests written for index
// triples: pairs sharing an edge intersect only when they fold onto each other (coplanar, on
// the same side of the edge), pairs sharing a vertex only when an opposite edge meets the
// other triangle, other pairs when the triangles meet at all.

#include "meshcheck/checks_cgal.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>
#include <utility>

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/self_intersections.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Side_of_triangle_mesh.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/box_intersection_d.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "meshcheck/intersections.h"

namespace sm::detail {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Triangle3 = Kernel::Triangle_3;
using Segment3 = Kernel::Segment_3;
using SurfaceMesh = CGAL::Surface_mesh<Point>;
namespace PMP = CGAL::Polygon_mesh_processing;

#if defined(CGAL_LINKED_WITH_TBB)
using Concurrency = CGAL::Parallel_tag;
#else
using Concurrency = CGAL::Sequential_tag;
#endif

using Pair = std::array<std::uint32_t, 2>;

// The side of q of the plane through a, b, c (+1 or -1) where floating point decides it for
// certain, else 0 (nearly coplanar, degenerate, or out of range: the exact predicates decide).
// The error bound is twenty times the one of CGAL's own static filter for orient3d (its
// Orientation_3 on translated coordinates), to cover this evaluation order.
int certain_side(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& q) {
  const glm::dvec3 u = b - a, v = c - a, w = q - a;
  const double mx = std::max({std::abs(u.x), std::abs(v.x), std::abs(w.x)});
  const double my = std::max({std::abs(u.y), std::abs(v.y), std::abs(w.y)});
  const double mz = std::max({std::abs(u.z), std::abs(v.z), std::abs(w.z)});
  constexpr double kLow = 1e-60, kHigh = 1e60;  // no underflow or overflow in the products
  if (!(std::min({mx, my, mz}) > kLow && std::max({mx, my, mz}) < kHigh)) return 0;
  const double det = glm::dot(w, glm::cross(u, v));
  const double bound = 20 * 5.1107127829973299e-15 * mx * my * mz;
  return det > bound ? 1 : det < -bound ? -1 : 0;
}

// certain_side for several points q against one plane through a, b, c: its normal and the
// sizes of its edges worked out once (the same operations, the same answers).
class CertainPlane {
 public:
  CertainPlane(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c)
      : a_(a), n_(glm::cross(b - a, c - a)) {
    const glm::dvec3 u = b - a, v = c - a;
    m_ = glm::dvec3(std::max(std::abs(u.x), std::abs(v.x)), std::max(std::abs(u.y), std::abs(v.y)),
                    std::max(std::abs(u.z), std::abs(v.z)));
  }
  [[nodiscard]] int side(const glm::dvec3& q) const {
    const glm::dvec3 w = q - a_;
    const double mx = std::max(m_.x, std::abs(w.x)), my = std::max(m_.y, std::abs(w.y)),
                 mz = std::max(m_.z, std::abs(w.z));
    constexpr double kLow = 1e-60, kHigh = 1e60;
    if (!(std::min({mx, my, mz}) > kLow && std::max({mx, my, mz}) < kHigh)) return 0;
    const double det = glm::dot(w, n_);
    const double bound = 20 * 5.1107127829973299e-15 * mx * my * mz;
    return det > bound ? 1 : det < -bound ? -1 : 0;
  }
  // Whether p, q and r are all on one side for certain.
  [[nodiscard]] bool all_on_one_side(const glm::dvec3& p, const glm::dvec3& q, const glm::dvec3& r) const {
    const int s = side(p);
    return s != 0 && side(q) == s && side(r) == s;
  }

 private:
  glm::dvec3 a_, n_, m_;
};

// The certain sides of p and q of the plane through a, b, c (certain_side); q's only where
// p's is certain (0 otherwise).
std::pair<int, int> certain_sides(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& p,
                                  const glm::dvec3& q) {
  const int s = certain_side(a, b, c, p);
  return {s, s != 0 ? certain_side(a, b, c, q) : 0};
}

// Whether the line through p and q passes outside the triangle abc for certain: the
// orientations of (p, q) against its three edges, all of one sign (or zero) when the line
// meets the triangle, have two certainly of opposite signs.
bool line_certainly_outside(const glm::dvec3& p, const glm::dvec3& q, const glm::dvec3& a, const glm::dvec3& b,
                            const glm::dvec3& c) {
  const int e0 = certain_side(p, q, a, b), e1 = certain_side(p, q, b, c), e2 = certain_side(p, q, c, a);
  return e0 * e1 < 0 || e1 * e2 < 0 || e0 * e2 < 0;
}

// Triangle pairs of a soup that intersect other than in their shared vertex or edge.
class SoupIntersector {
 public:
  // The boxes are taken about the first vertex: at georeferenced coordinates (UTM northings
  // of 5e6 m) a float's step is half a metre, and every box rounded outwards to it overlapped
  // a thousand others on a messy tree (86 M box pairs for 89 k triangles, not 1 M).
  explicit SoupIntersector(const Mesh& mesh)
      : mesh_(mesh), origin_(mesh.positions.empty() ? glm::dvec3(0) : mesh.positions.front()) {}

  /// The intersecting pairs among all triangles.
  std::vector<Pair> run() const {
    std::vector<std::uint32_t> all(mesh_.triangles.size());
    for (std::size_t t = 0; t < all.size(); ++t) all[t] = static_cast<std::uint32_t>(t);
    return run(all);
  }

  /// The intersecting pairs among `triangles` (i < j), in any order.
  ///
  /// Large sets are cut into slabs along the longest axis of their boxes, searched in
  /// parallel, each with CGAL's sequential box intersection: a pair is reported by the slab
  /// holding the lower end of its boxes' overlap on that axis (both boxes reach into that
  /// slab), so once. CGAL's own parallel search splits the boxes by their order rather than
  /// by place and gained 12 % on two threads (the fold repair's first round on the large
  /// grown tree: 240 k triangles, 1.8 M overlapping boxes).
  // Single-precision boxes, rounded outwards (a box never shrinks: the same pairs reach the
  // exact test), identified by their address: 32 bytes a box rather than 64, and the search
  // is bound by their memory.
  using Box = CGAL::Box_intersection_d::Box_with_info_d<float, 3, std::uint32_t,
                                                        CGAL::Box_intersection_d::ID_FROM_BOX_ADDRESS>;

  /// The intersecting pairs with one triangle in `triangles` and the other anywhere (both
  /// orders, possibly twice).
  ///
  /// The other triangles whose boxes can meet one of theirs are found first, in parallel, by
  /// a grid of cells over the given boxes (marked where a box reaches; a triangle whose box
  /// reaches no marked cell meets none of them): after a local edit, most of the mesh is
  /// far from it, and its boxes need not be made nor sorted. The same pairs as a search
  /// against every box.
  std::vector<Pair> run_touching(const std::vector<std::uint32_t>& triangles) const {
    std::vector<Box> some = boxes(triangles);
    std::vector<Pair> found;
    if (some.empty()) return found;
    // The grid: about 8 cells per given box, at most 2^21 in all, over their bounds.
    float lo[3], hi[3];
    for (int d = 0; d < 3; ++d) {
      lo[d] = some.front().min_coord(d);
      hi[d] = some.front().max_coord(d);
    }
    for (const Box& b : some) {
      for (int d = 0; d < 3; ++d) {
        lo[d] = std::min(lo[d], b.min_coord(d));
        hi[d] = std::max(hi[d], b.max_coord(d));
      }
    }
    const double cells_wanted = std::clamp(8.0 * double(some.size()), 1.0, double(1 << 21));
    double extent[3], volume = 1;
    for (int d = 0; d < 3; ++d) {
      extent[d] = std::max(double(hi[d]) - double(lo[d]), 1e-30);
      volume *= extent[d];
    }
    const double cell = std::cbrt(volume / cells_wanted);
    std::array<std::size_t, 3> n{};
    for (int d = 0; d < 3; ++d) n[d] = std::clamp<std::size_t>(std::size_t(extent[d] / cell) + 1, 1, 1 << 10);
    auto cell_of = [&](int d, float x) {  // monotone in x, clamped to the grid
      const double t = (double(x) - double(lo[d])) / extent[d] * double(n[d]);
      return static_cast<std::size_t>(std::clamp(t, 0.0, double(n[d] - 1)));
    };
    std::vector<std::uint8_t> marked(n[0] * n[1] * n[2], 0);
    // (Large boxes would mark most of the grid at a high cost: then every cell is marked.)
    std::size_t reach = 0;
    for (const Box& b : some) {
      std::size_t cells = 1;
      for (int d = 0; d < 3; ++d) cells *= cell_of(d, b.max_coord(d)) - cell_of(d, b.min_coord(d)) + 1;
      reach += cells;
    }
    if (reach > 8 * marked.size()) std::fill(marked.begin(), marked.end(), std::uint8_t{1});
    for (const Box& b : reach > 8 * marked.size() ? std::vector<Box>{} : some) {
      for (std::size_t z = cell_of(2, b.min_coord(2)); z <= cell_of(2, b.max_coord(2)); ++z) {
        for (std::size_t y = cell_of(1, b.min_coord(1)); y <= cell_of(1, b.max_coord(1)); ++y) {
          for (std::size_t x = cell_of(0, b.min_coord(0)); x <= cell_of(0, b.max_coord(0)); ++x)
            marked[(z * n[1] + y) * n[0] + x] = 1;
        }
      }
    }
    const std::size_t nf = mesh_.triangles.size();
    constexpr std::size_t kChunk = 1 << 14;
    std::vector<std::vector<std::uint32_t>> part((nf + kChunk - 1) / kChunk);
    tbb::parallel_for(std::size_t{0}, part.size(), [&](std::size_t k) {
      for (std::size_t f = k * kChunk; f < std::min(nf, (k + 1) * kChunk); ++f) {
        const Box b = float_box(static_cast<std::uint32_t>(f));
        bool outside = false;
        for (int d = 0; d < 3; ++d) outside = outside || b.max_coord(d) < lo[d] || b.min_coord(d) > hi[d];
        if (outside) continue;
        bool near = false;
        for (std::size_t z = cell_of(2, b.min_coord(2)); !near && z <= cell_of(2, b.max_coord(2)); ++z) {
          for (std::size_t y = cell_of(1, b.min_coord(1)); !near && y <= cell_of(1, b.max_coord(1)); ++y) {
            for (std::size_t x = cell_of(0, b.min_coord(0)); !near && x <= cell_of(0, b.max_coord(0)); ++x)
              near = marked[(z * n[1] + y) * n[0] + x] != 0;
          }
        }
        if (near) part[k].push_back(static_cast<std::uint32_t>(f));
      }
    });
    std::vector<std::uint32_t> candidates;
    for (const auto& p : part) candidates.insert(candidates.end(), p.begin(), p.end());
    const std::vector<Box> every = boxes(candidates);
    // Searched in slabs along the given boxes' longest axis, in parallel, as in run(): a pair
    // belongs to the slab that holds the lower end of its boxes' overlap on that axis (a
    // volume patch's fresh triangles, half of messy seed 200's mesh time on one thread).
    int axis = 0;
    for (int d = 1; d < 3; ++d) {
      if (extent[d] > extent[axis]) axis = d;
    }
    constexpr std::size_t kSlabBoxes = 20000;  // fewer given and candidate boxes: one search
    const std::size_t total = some.size() + every.size();
    const std::size_t slabs = total < kSlabBoxes ? 1 : std::clamp<std::size_t>(total / kSlabBoxes, 2, 16);
    const Slabs slab(some, axis, slabs);
    std::vector<std::vector<Pair>> in_slab(slabs);
    tbb::parallel_for(std::size_t{0}, slabs, [&](std::size_t s) {
      std::vector<const Box*> mine = slab.reaching(some, s), theirs = slab.reaching(every, s);
      auto callback = [&](const Box* a, const Box* b) {
        if (!slab.holds(s, *a, *b)) return;  // another slab's pair
        const std::uint32_t i = a->info(), j = b->info();
        if (i != j && intersect(i, j)) in_slab[s].push_back({std::min(i, j), std::max(i, j)});
      };
      CGAL::box_intersection_d<CGAL::Sequential_tag>(mine.begin(), mine.end(), theirs.begin(), theirs.end(), callback,
                                                     std::ptrdiff_t{1000}, CGAL::Box_intersection_d::CLOSED,
                                                     CGAL::Box_intersection_d::BIPARTITE);
    });
    for (const auto& f : in_slab) found.insert(found.end(), f.begin(), f.end());
    return found;
  }

  /// Slabs of a search along one axis: a pair of boxes belongs to the slab holding the lower
  /// end of their overlap on that axis, so each pair is reported by one slab.
  struct Slabs {
    // Cuts at equal shares of the boxes' lower ends (order statistics at increasing ranks:
    // ascending). Each is searched for only above the one before (nth_element leaves the
    // larger values there): one pass over the values in all rather than one per cut.
    Slabs(const std::vector<Box>& boxes, int along, std::size_t count) : axis(along), slabs(count) {
      if (slabs < 2) return;
      std::vector<double> mins(boxes.size());
      for (std::size_t k = 0; k < boxes.size(); ++k) mins[k] = boxes[k].min_coord(axis);
      auto from = mins.begin();
      for (std::size_t s = 1; s < slabs; ++s) {
        const auto at = mins.begin() + std::ptrdiff_t(s * mins.size() / slabs);
        std::nth_element(from, at, mins.end());
        cut.push_back(*at);
        from = at + 1;
      }
    }
    [[nodiscard]] double from(std::size_t s) const { return s == 0 ? -HUGE_VAL : cut[s - 1]; }
    [[nodiscard]] double to(std::size_t s) const { return s + 1 == slabs ? HUGE_VAL : cut[s]; }
    /// The boxes reaching into slab s (all of them where there is one slab).
    [[nodiscard]] std::vector<const Box*> reaching(const std::vector<Box>& boxes, std::size_t s) const {
      std::vector<const Box*> ptrs;
      for (const Box& b : boxes) {
        if (slabs == 1 || (double(b.min_coord(axis)) < to(s) && double(b.max_coord(axis)) >= from(s))) ptrs.push_back(&b);
      }
      return ptrs;
    }
    /// Whether the overlap of a and b starts in slab s.
    [[nodiscard]] bool holds(std::size_t s, const Box& a, const Box& b) const {
      if (slabs == 1) return true;
      const double start = double(std::max(a.min_coord(axis), b.min_coord(axis)));
      return start >= from(s) && start < to(s);
    }
    int axis;
    std::size_t slabs;
    std::vector<double> cut;  // slab s holds overlaps starting in [cut[s - 1], cut[s])
  };

  /// The box of triangle t about origin_, in single precision rounded outwards. (Two boxes
  /// that overlap still do: the subtraction and the rounding keep the order of coordinates.)
  [[nodiscard]] Box float_box(std::uint32_t t) const {
    const auto& tri = mesh_.triangles[t];
    const glm::dvec3 &p = mesh_.positions[tri[0]], &q = mesh_.positions[tri[1]], &r = mesh_.positions[tri[2]];
    float lo[3], hi[3];
    for (int d = 0; d < 3; ++d) {
      const double a = std::min({p[d], q[d], r[d]}) - origin_[d], b = std::max({p[d], q[d], r[d]}) - origin_[d];
      lo[d] = static_cast<float>(a);
      hi[d] = static_cast<float>(b);
      if (double(lo[d]) > a) lo[d] = std::nextafter(lo[d], -HUGE_VALF);
      if (double(hi[d]) < b) hi[d] = std::nextafter(hi[d], HUGE_VALF);
    }
    return Box(lo, hi, t);
  }

  /// The boxes of the non-degenerate triangles of `triangles`.
  std::vector<Box> boxes(const std::vector<std::uint32_t>& triangles) const {
    std::vector<Box> all(triangles.size());
    std::vector<std::uint8_t> valid(triangles.size(), 0);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, triangles.size(), 4096),
                      [&](const tbb::blocked_range<std::size_t>& range) {
                        for (std::size_t k = range.begin(); k != range.end(); ++k) {
                          const std::uint32_t t = triangles[k];
                          const auto& tri = mesh_.triangles[t];
                          const Point p = point(tri[0]), q = point(tri[1]), r = point(tri[2]);
                          if (tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2] || CGAL::collinear(p, q, r))
                            continue;  // degenerate
                          all[k] = float_box(t);
                          valid[k] = 1;
                        }
                      });
    std::vector<Box> out;
    out.reserve(all.size());
    for (std::size_t k = 0; k < all.size(); ++k) {
      if (valid[k]) out.push_back(all[k]);
    }
    return out;
  }

  std::vector<Pair> run(const std::vector<std::uint32_t>& triangles) const {
    const std::vector<Box> boxes = this->boxes(triangles);
    // Below 1000 boxes the two-way scan beats further splitting (the default cutoff is 10):
    // 231 k triangles of the fold repair's first round, 0.62 -> 0.28 s.
    constexpr std::ptrdiff_t kCutoff = 1000;
    // From kSlabBoxes boxes on, at least two slabs (one per thread of the test machine: the
    // fold repair's second round on the large grown tree, 25 k triangles, 20 -> 11 ms).
    constexpr std::size_t kSlabBoxes = 20000;  // fewer: one search
    const std::size_t slabs = boxes.size() < kSlabBoxes ? 1 : std::clamp<std::size_t>(boxes.size() / kSlabBoxes, 2, 16);
    int axis = 0;
    if (slabs > 1) {
      double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
      for (const Box& b : boxes) {
        for (int d = 0; d < 3; ++d) {
          lo[d] = std::min(lo[d], double(b.min_coord(d)));
          hi[d] = std::max(hi[d], double(b.max_coord(d)));
        }
      }
      for (int d = 1; d < 3; ++d) {
        if (hi[d] - lo[d] > hi[axis] - lo[axis]) axis = d;
      }
    }
    const Slabs slab(boxes, axis, slabs);
    std::vector<std::vector<Pair>> found(slabs);
    tbb::parallel_for(std::size_t{0}, slabs, [&](std::size_t s) {
      std::vector<const Box*> ptrs = slab.reaching(boxes, s);
      auto callback = [&](const Box* a, const Box* b) {
        if (!slab.holds(s, *a, *b)) return;  // another slab's pair
        const std::uint32_t i = a->info(), j = b->info();
        if (intersect(i, j)) found[s].push_back({std::min(i, j), std::max(i, j)});
      };
      CGAL::box_self_intersection_d<CGAL::Sequential_tag>(ptrs.begin(), ptrs.end(), callback, kCutoff);
    });
    std::vector<Pair> pairs;
    for (const auto& f : found) pairs.insert(pairs.end(), f.begin(), f.end());
    return pairs;
  }

  /// Whether triangles i and j intersect other than in their shared vertex or edge.
  [[nodiscard]] bool intersect(std::uint32_t i, std::uint32_t j) const {
    const auto& a = mesh_.triangles[i];
    const auto& b = mesh_.triangles[j];
    int shared = 0, sa = -1, sb = -1;
    for (int x = 0; x < 3; ++x) {
      for (int y = 0; y < 3; ++y) {
        if (a[static_cast<std::size_t>(x)] == b[static_cast<std::size_t>(y)]) {
          ++shared;
          sa = x;
          sb = y;
        }
      }
    }
    // Most pairs the box search reports are neighbours far from touching; where floating
    // point shows a separating plane for certain, the exact tests are skipped (the same answer,
    // at a fraction of the cost: 1.76 M pairs in the fold repair's first round on the large
    // grow preset).
    auto position = [&](const Mesh::Triangle& t, int k) -> const glm::dvec3& {
      return mesh_.positions[t[static_cast<std::size_t>((k % 3 + 3) % 3)]];
    };
    auto pt = [&](const Mesh::Triangle& t, int k) {
      const glm::dvec3& p = position(t, k);
      return Point(p.x, p.y, p.z);
    };
    const glm::dvec3 &a0 = position(a, 0), &a1 = position(a, 1), &a2 = position(a, 2);
    const glm::dvec3 &b0 = position(b, 0), &b1 = position(b, 1), &b2 = position(b, 2);
    if (shared == 0) {
      if (CertainPlane(a0, a1, a2).all_on_one_side(b0, b1, b2)) return false;
      if (CertainPlane(b0, b1, b2).all_on_one_side(a0, a1, a2)) return false;
    } else if (shared == 1) {
      // One opposite edge strictly on one side of the other triangle's plane suffices: were
      // b's opposite edge to meet triangle a at x, the line from the shared vertex through x
      // (in b's plane) would leave a across a's opposite edge, which would then touch b's
      // plane; and an edge off b's plane cannot meet b.
      const glm::dvec3 &p = position(b, sb + 1), &q = position(b, sb + 2);  // b's opposite edge
      const glm::dvec3 &r = position(a, sa + 1), &t = position(a, sa + 2);  // a's
      const auto [sp, sq] = certain_sides(a0, a1, a2, p, q);
      if (sp != 0 && sq == sp) return false;
      const auto [sr, st] = certain_sides(b0, b1, b2, r, t);
      if (sr != 0 && st == sr) return false;
      // Else both opposite edges missing the other triangle (the exact test below), decided
      // in floating point where each edge crosses the other's plane and its line passes
      // outside the other triangle (the fold repair's first round on the bench tree sent 76 k
      // such pairs to the exact test).
      if (sp * sq < 0 && sr * st < 0 && line_certainly_outside(p, q, a0, a1, a2) &&
          line_certainly_outside(r, t, b0, b1, b2))
        return false;
    }
    const Triangle3 ta(pt(a, 0), pt(a, 1), pt(a, 2)), tb(pt(b, 0), pt(b, 1), pt(b, 2));
    switch (shared) {
      case 0:
        return CGAL::do_intersect(ta, tb);
      case 1:
        return CGAL::do_intersect(ta, Segment3(pt(b, sb + 1), pt(b, sb + 2))) ||
               CGAL::do_intersect(tb, Segment3(pt(a, sa + 1), pt(a, sa + 2)));
      case 2: {
        // The vertex of each triangle that is not on the shared edge.
        int ca = 0, cb = 0;
        for (int x = 0; x < 3; ++x) {
          const auto v = a[static_cast<std::size_t>(x)];
          if (v != b[0] && v != b[1] && v != b[2]) ca = x;
        }
        for (int y = 0; y < 3; ++y) {
          const auto v = b[static_cast<std::size_t>(y)];
          if (v != a[0] && v != a[1] && v != a[2]) cb = y;
        }
        // (Neighbours across an edge are rarely coplanar: decided in floating point where it
        // can be, 365 k pairs of the bench tree's fold repair.)
        if (certain_side(position(a, ca + 1), position(a, ca + 2), position(a, ca), position(b, cb)) != 0) return false;
        const Point s0 = pt(a, ca + 1), s1 = pt(a, ca + 2), c = pt(a, ca), d = pt(b, cb);
        return CGAL::coplanar(s0, s1, c, d) && CGAL::coplanar_orientation(s0, s1, c, d) == CGAL::POSITIVE;
      }
      default:
        return true;  // the same three vertices: the triangles coincide
    }
  }

 private:
  // The mesh's positions are read at each test (no copy: on a 3.4 M-triangle mesh, copying
  // them took a fifth of the fold repair's first-round search).
  [[nodiscard]] Point point(std::uint32_t v) const {
    const glm::dvec3& p = mesh_.positions[v];
    return {p.x, p.y, p.z};
  }
  const Mesh& mesh_;
  glm::dvec3 origin_;  ///< the boxes' origin (the positions may change after it was taken)
};

}  // namespace

CgalCheckResult run_cgal_checks(const Mesh& mesh, bool polygon_mesh, bool closed_polygon_mesh, bool self_intersections,
                                const std::vector<glm::dvec3>& queries, std::size_t max_examples) {
  CgalCheckResult result;
  Stopwatch watch;
  std::vector<Point> points;
  points.reserve(mesh.positions.size());
  for (const auto& p : mesh.positions) points.emplace_back(p.x, p.y, p.z);

  SurfaceMesh sm;
  if (polygon_mesh) {
    std::vector<std::array<std::size_t, 3>> polygons(mesh.triangles.size());
    for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
      polygons[t] = {mesh.triangles[t][0], mesh.triangles[t][1], mesh.triangles[t][2]};
    }
    // Faces are created in polygon order, so face index == triangle index.
    PMP::polygon_soup_to_polygon_mesh(points, polygons, sm);
    // Should CGAL have refused a face after all, the indices would no longer match: use the
    // soup path instead.
    if (sm.number_of_faces() != polygons.size() || !sm.is_valid(false)) {
      polygon_mesh = closed_polygon_mesh = false;
      sm.clear();
    }
  }
  result.timings.add("cgal_mesh", watch.lap());

  if (self_intersections) {
    std::vector<Pair> pairs;
    if (polygon_mesh) {
      std::vector<std::pair<SurfaceMesh::Face_index, SurfaceMesh::Face_index>> faces;
      PMP::self_intersections<Concurrency>(sm, std::back_inserter(faces));
      for (const auto& [f, g] : faces) {
        if (f == g) continue;  // CGAL's report of a degenerate face; counted by check_mesh
        const auto i = static_cast<std::uint32_t>(f.idx()), j = static_cast<std::uint32_t>(g.idx());
        pairs.push_back({std::min(i, j), std::max(i, j)});
      }
    } else {
      pairs = SoupIntersector(mesh).run();
    }
    // Parallel runs report in any order; sorting makes the report deterministic.
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    result.self_intersections_checked = true;
    result.self_intersecting_pairs = pairs.size();
    pairs.resize(std::min(pairs.size(), max_examples));
    result.examples = std::move(pairs);
    result.timings.add("self_intersections", watch.lap());
  }

  if (closed_polygon_mesh && !queries.empty() && !mesh.triangles.empty()) {
    // Every query in one pass over the triangles (core/mesh.h winding_numbers): the signed
    // count of ray crossings, 2 inside two overlapping parts. (One CGAL ray query per node
    // did not finish in 40 min on a 1,000,000-node chain.)
    const std::vector<int> winding = winding_numbers(mesh, queries);
    result.inside.resize(queries.size());
    std::vector<std::size_t> outside;
    for (std::size_t i = 0; i < queries.size(); ++i) {
      result.inside[i] = winding[i] >= 1 ? 1 : 0;
      result.inside_by_winding += winding[i] >= 2 ? 1 : 0;
      if (!result.inside[i]) outside.push_back(i);
    }
    // The solid includes its surface: a node on a flat cap (winding number 1/2, rounded
    // either way) counts as inside where CGAL's exact test puts it on the boundary.
    if (!outside.empty()) {
      const CGAL::Side_of_triangle_mesh<SurfaceMesh, Kernel> side(sm);
      for (const std::size_t i : outside) {
        if (side(Point(queries[i].x, queries[i].y, queries[i].z)) == CGAL::ON_BOUNDARY) result.inside[i] = 1;
      }
    }
    result.inside_checked = true;
    result.timings.add("inside", watch.lap());
  }
  return result;
}

}  // namespace sm::detail

namespace sm {

struct TriangleIntersections::Impl {
  explicit Impl(const Mesh& mesh) : intersector(mesh) {}
  detail::SoupIntersector intersector;
};

TriangleIntersections::TriangleIntersections(const Mesh& mesh) : impl_(std::make_unique<Impl>(mesh)) {}
TriangleIntersections::~TriangleIntersections() = default;

bool TriangleIntersections::intersect(std::uint32_t i, std::uint32_t j) const {
  return impl_->intersector.intersect(i, j);
}

std::vector<std::array<std::uint32_t, 2>> TriangleIntersections::pairs(
    const std::vector<std::uint32_t>& triangles) const {
  std::vector<std::array<std::uint32_t, 2>> found = impl_->intersector.run(triangles);
  std::sort(found.begin(), found.end());  // found in parallel, in any order
  found.erase(std::unique(found.begin(), found.end()), found.end());
  return found;
}

std::vector<std::array<std::uint32_t, 2>> TriangleIntersections::pairs_touching(
    const std::vector<std::uint32_t>& triangles) const {
  std::vector<std::array<std::uint32_t, 2>> found = impl_->intersector.run_touching(triangles);
  std::sort(found.begin(), found.end());
  found.erase(std::unique(found.begin(), found.end()), found.end());
  return found;
}

std::vector<std::array<std::uint32_t, 3>> triangulate_polyline(const std::vector<glm::dvec3>& loop,
                                                               const std::vector<glm::dvec3>& outside) {
  std::vector<std::array<std::uint32_t, 3>> out;
  if (loop.size() < 3 || (!outside.empty() && outside.size() != loop.size())) return out;
  auto point = [](const glm::dvec3& p) { return detail::Point(p.x, p.y, p.z); };
  std::vector<detail::Point> points, third;
  for (const auto& p : loop) points.push_back(point(p));
  for (const auto& p : outside) third.push_back(point(p));
  std::vector<std::tuple<int, int, int>> triangles;
  // Liepa's dynamic programme over all triangulations, not over the faces of a 3D Delaunay
  // triangulation: the latter's result depended on the heap (the thread count), measured.
  detail::PMP::triangulate_hole_polyline(points, third, std::back_inserter(triangles),
                                         CGAL::parameters::use_delaunay_triangulation(false));
  // A complete triangulation of an n-gon has n - 2 triangles; CGAL leaves holes when it fails.
  if (triangles.size() != loop.size() - 2) return out;
  for (const auto& [i, j, k] : triangles) {
    out.push_back({static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j), static_cast<std::uint32_t>(k)});
  }
  return out;
}

}  // namespace sm
