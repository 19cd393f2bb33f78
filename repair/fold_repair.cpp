// Fold repair by edge flips and bounded vertex moves (see fold_repair.h).
//
// A flip replaces the edge (a, b) of triangles (a, b, c) and (b, a, d) by (c, d): the same
// four vertices, the quad's outline unchanged, so the mesh stays closed and manifold with the
// same Euler characteristic. It is made only when (c, d) is not an edge already (that would
// make the mesh non-manifold), both new triangles face the way the pair did, and the number
// of intersecting pairs among the triangles within two rings of the intersecting pair drops.
// A vertex move (towards the centroid of the vertex's neighbours, 1, 1/2 or 1/4 of the way,
// or along the normal of its fan, out or in, by max_move or half of it; in all within
// max_move of where stitching put it, up to a step of the float grid the
// position is rounded to) is judged the same way and refused when it turns a
// triangle around the vertex over. Where neither helps, an edge collapse (optional; u and w
// become one vertex at u, at w or midway, and the edge's two triangles go) is judged the same
// way too: it needs the link condition (u and w share exactly the two neighbours across the
// edge), so the mesh stays closed and manifold with the same Euler characteristic. The last
// resort, a refill, replaces a disk of triangles around the pair (the star of one of its
// vertices, whose inner vertex goes; else the triangles within 1, 2 or 3 rings of the pair or
// of either triangle: two sheets through each other often have one folded) by CGAL's
// hole-filling triangulation of its boundary loop, oriented like the disk; a disk for a disk
// keeps the Euler characteristic, and a new inner edge that is an edge elsewhere already is
// refused. It too must lower the crossings, of the disk with itself and the two rings around it.

#include "repair/fold_repair.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <cstdint>
#include <deque>
#include <iterator>
#include <map>
#include <numbers>
#include <numeric>
#include <span>
#include <unordered_set>
#include <utility>

#include <glm/glm.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/math.h"
#include "meshcheck/intersections.h"

namespace sm {

namespace {

constexpr int kMaxFlipsPerPair = 8;
// A refill replaces the disk within 1, 2, ... this many rings of a pair.
constexpr int kMaxRefillRings = 3;
// Longest boundary loop a refill triangulates (the search is O(n^3) in it). Disks around a
// pair on the samples have boundaries of up to 186 vertices (boutdenoylum2); around the fans
// of long triangles in a tangle (a hub of 5,000 twigs) up to 1,300, and the repair took
// 284 s on a mesh of 17,000 triangles (25 s with this limit).
constexpr std::size_t kMaxRefillLoop = 200;
// Twice the area of a sliver, relative to its longest edge squared (about 0.0001 degrees).
constexpr double kSliver = 1e-6;
// Folds show as creases: the examined triangles are the suspect ones where the surface turns
// by more than this across an edge, and those sharing a vertex with them. (Large grown tree:
// 1.4 M suspect triangles; 27 k creased; examined with one ring 232 k, finding 1,483 of the
// 1,519 pairs, with two rings 603 k finding all, at twice the time and the same quality on
// the samples.)
constexpr double kCreaseDegrees = 90.0;

class FoldRepair {
 public:
  FoldRepair(Mesh& mesh, const std::vector<std::uint8_t>& suspect, const std::vector<double>& max_move,
             const FoldRepairOptions& options, FoldRepairUndo* undo)
      : mesh_(mesh),
        suspect_(suspect),
        max_move_(max_move),
        collapse_(options.collapse),
        refill_(options.refill),
        max_pairs_(options.max_pairs),
        max_tests_(options.max_tests_per_triangle * mesh.triangles.size() + options.min_tests),
        keep_side_(options.keep_side),
        axis_point_(options.axis_point),
        axis_targets_(options.axis_targets),
        grid_(options.grid),
        undo_(undo),
        test_(mesh) {}

  // Round 0 examines the creased suspect triangles and their neighbours (creased()); each
  // later round only the triangles within two rings of those the previous round flipped or
  // moved (elsewhere nothing changed).
  FoldRepairStats run(int max_rounds) {
    FoldRepairStats stats;
    build_around();
    std::vector<std::uint32_t> examine = creased();
    std::size_t handled = 0;
    for (int round = 0; !stats.gave_up && !stats.out_of_tests && round < max_rounds && !examine.empty(); ++round) {
      const auto pairs = test_.pairs(examine);
      ++stats.rounds;
      if (round == 0) stats.found = pairs.size();
      if (pairs.empty()) break;
      if (round == 0 && pairs.size() > max_pairs_) {
        stats.gave_up = true;
        break;
      }
      flipped_.clear();
      for (const auto& [a, b] : pairs) {
        if (++handled > 4 * max_pairs_) {
          stats.gave_up = true;
          break;
        }
        if (tests_ > max_tests_) {
          stats.out_of_tests = true;
          break;
        }
        // Flip while that lowers the crossings around the pair, even once a and b are
        // apart: their neighbours often cross too.
        if (!alive(a) || !alive(b) || !intersect(a, b)) continue;  // untangled by an earlier change
        for (int k = 0; k < kMaxFlipsPerPair && flip_one_edge_of(a, b); ++k) {
        }
        auto crossing = [&, a = a, b = b] { return alive(a) && alive(b) && intersect(a, b); };  // (clang 14: no captured bindings)
        for (int k = 0; k < kMaxFlipsPerPair && crossing() && move_one_vertex_of(a, b); ++k) ++stats.moves;
        for (int k = 0; collapse_ && k < kMaxFlipsPerPair && crossing() && collapse_one_edge_of(a, b); ++k)
          ++stats.collapses;
        // Around the pair, then around either triangle (two sheets through each other: one
        // of them folded).
        if (refill_ && crossing()) {
          // The star of a vertex of the pair (a disk on a closed 2-manifold), then larger disks.
          // (Stars first, measured: samples x seeds 1-3, 311 -> 252 pairs; the rings alone are
          // often annuli around a thin tube or a fused hub.)
          std::vector<std::uint32_t> corners;
          for (const std::uint32_t f : {a, b}) {
            for (const std::uint32_t v : mesh_.triangles[f]) corners.push_back(v);
          }
          for (const std::uint32_t v : corners) {
            if (!crossing()) break;
            const auto here = around(v);
            std::vector<std::uint32_t> star(here.begin(), here.end());
            std::sort(star.begin(), star.end());
            if (movable(v) && refill(star)) ++stats.refills;
          }
        }
        for (int rings = 1; refill_ && rings <= kMaxRefillRings && crossing(); ++rings) {
          for (const std::vector<std::uint32_t>& seeds : {std::vector{a, b}, std::vector{a}, std::vector{b}}) {
            if (crossing() && refill(within_rings(seeds, rings))) ++stats.refills;
          }
        }
        if (crossing()) stats.left.emplace_back(std::min(a, b), std::max(a, b));
      }
      stats.flips += flipped_.size() / 2;  // before the moved triangles join the list
      flipped_.insert(flipped_.end(), moved_.begin(), moved_.end());
      moved_.clear();
      std::erase_if(flipped_, [&](std::uint32_t f) { return !alive(f); });
      examine = within_two_rings(flipped_);
    }
    // (Later changes around a pair may have untangled it.)
    std::sort(stats.left.begin(), stats.left.end());
    stats.left.erase(std::unique(stats.left.begin(), stats.left.end()), stats.left.end());
    std::erase_if(stats.left, [&](const auto& ab) {
      return !alive(ab.first) || !alive(ab.second) || !intersect(ab.first, ab.second);
    });
    return stats;
  }

 private:
  using Box = std::pair<glm::dvec3, glm::dvec3>;

  // Triangles around each vertex: a compressed table of the stitched mesh, and a copy per
  // vertex whose triangles a flip changed (a few thousand at most; far cheaper than a list
  // per vertex), found through the vertex's slot rather than an ordered map (the repair asks
  // for the triangles around a vertex tens of times per pair; large grown tree's first round
  // 42.6 -> 41.3 ms).
  void build_around() {
    VertexCorners corners = vertex_corners(mesh_);
    around_begin_ = std::move(corners.begin);
    around_flat_ = std::move(corners.corner);
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, around_flat_.size(), 1 << 16),
                      [&](const tbb::blocked_range<std::size_t>& r) {
                        for (std::size_t i = r.begin(); i != r.end(); ++i) around_flat_[i] /= 3;  // corner -> triangle
                      });
    changed_slot_.assign(mesh_.positions.size(), kUnchanged);
  }

  [[nodiscard]] std::span<const std::uint32_t> around(std::uint32_t v) const {
    if (const std::uint32_t slot = changed_slot_[v]; slot != kUnchanged) return changed_lists_[slot];
    return {around_flat_.data() + around_begin_[v], around_begin_[v + 1] - around_begin_[v]};
  }

  std::vector<std::uint32_t>& changed(std::uint32_t v) {
    std::uint32_t& slot = changed_slot_[v];
    if (slot == kUnchanged) {
      slot = static_cast<std::uint32_t>(changed_lists_.size());
      const auto a = around_flat_.begin() + around_begin_[v], b = around_flat_.begin() + around_begin_[v + 1];
      changed_lists_.emplace_back(a, b);
    }
    return changed_lists_[slot];
  }

  // The suspect triangles with a crease (an edge where the surface turns by more than
  // kCreaseDegrees) and the triangles sharing a vertex with them (within_rings(creased, 1),
  // as vertex flags in two parallel passes: its sorts were a serial 14 ms of the large grown
  // tree).
  [[nodiscard]] std::vector<std::uint32_t> creased() const {
    const double cos_crease = std::cos(kCreaseDegrees * std::numbers::pi / 180.0);
    const std::size_t nf = mesh_.triangles.size();
    constexpr std::size_t kChunk = 1 << 14;
    const std::size_t chunks = (nf + kChunk - 1) / kChunk;
    auto for_chunks = [&](auto&& body) {
      tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t k) {
        for (std::size_t f = k * kChunk; f < std::min(nf, (k + 1) * kChunk); ++f)
          body(k, static_cast<std::uint32_t>(f));
      });
    };
    // The creased triangles' vertices.
    std::vector<std::uint8_t> near(mesh_.positions.size(), 0);
    for_chunks([&](std::size_t, std::uint32_t f) {
      if (!suspect_[f]) return;
      const auto& t = mesh_.triangles[f];
      const glm::dvec3 n = mesh_.face_normal(t);
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t g = across_near(f, t[std::size_t(e)], t[std::size_t((e + 1) % 3)]);
        if (g == UINT32_MAX) continue;
        const glm::dvec3 m = mesh_.face_normal(mesh_.triangles[g]);
        const double len = glm::length(n) * glm::length(m);
        if (!(glm::dot(n, m) > cos_crease * len)) {
          for (const std::uint32_t v : t) std::atomic_ref<std::uint8_t>(near[v]).store(1, std::memory_order_relaxed);
          return;
        }
      }
    });
    // Every triangle with such a vertex, in order (fixed chunks, concatenated).
    std::vector<std::vector<std::uint32_t>> part(chunks);
    for_chunks([&](std::size_t k, std::uint32_t f) {
      const auto& t = mesh_.triangles[f];
      if (near[t[0]] || near[t[1]] || near[t[2]]) part[k].push_back(f);
    });
    std::vector<std::uint32_t> out;
    for (const auto& p : part) out.insert(out.end(), p.begin(), p.end());
    return out;
  }

  // Tries the edges of triangles a and b in order; makes the first flip that lowers the
  // number of intersections around it.
  bool flip_one_edge_of(std::uint32_t a, std::uint32_t b) {
    const std::vector<std::uint32_t> region = around_pair(a, b);
    // The region's boxes, once for the six tries: a try changes only its own two triangles,
    // which crossings() boxes afresh, and puts them back unless it is kept (the last try).
    std::vector<Box>& boxes = scratch_region_boxes_;
    boxes.resize(region.size());
    for (std::size_t k = 0; k < region.size(); ++k) boxes[k] = box(region[k]);
    for (const std::uint32_t f : {a, b}) {
      for (int e = 0; e < 3; ++e) {
        const Mesh::Triangle t = mesh_.triangles[f];
        if (try_flip(f, t[std::size_t(e)], t[std::size_t((e + 1) % 3)], region, boxes)) return true;
      }
    }
    return false;
  }

  // The triangles within two rings of triangles a and b, sorted: a flip of an edge of a or b
  // is judged by the crossings of its two triangles with these. (Two rings around the pair
  // rather than around the flipped quad measured better: boutdenoylum2 110 vs 253 pairs left.)
  [[nodiscard]] std::vector<std::uint32_t> around_pair(std::uint32_t a, std::uint32_t b) const {
    return within_two_rings({a, b});
  }

  [[nodiscard]] std::vector<std::uint32_t> within_two_rings(const std::vector<std::uint32_t>& faces) const {
    return within_rings(faces, 2);
  }
  // (Sorted once at the end: each ring is found as a set, through marks stamped with a
  // fresh number per call rather than by sorting.)
  [[nodiscard]] std::vector<std::uint32_t> within_rings(const std::vector<std::uint32_t>& faces, int rings) const {
    if (vertex_mark_.size() != mesh_.positions.size()) vertex_mark_.assign(mesh_.positions.size(), 0);
    if (triangle_mark_.size() != mesh_.triangles.size()) triangle_mark_.assign(mesh_.triangles.size(), 0);
    std::vector<std::uint32_t> verts, out = faces;
    for (int ring = 0; ring < rings; ++ring) {
      const std::uint32_t stamp = ++stamp_;
      verts.clear();
      for (const std::uint32_t g : out) {
        for (const std::uint32_t v : mesh_.triangles[g]) {
          if (vertex_mark_[v] != stamp) {
            vertex_mark_[v] = stamp;
            verts.push_back(v);
          }
        }
      }
      out.clear();
      for (const std::uint32_t v : verts) {
        for (const std::uint32_t g : around(v)) {
          if (triangle_mark_[g] != stamp) {
            triangle_mark_[g] = stamp;
            out.push_back(g);
          }
        }
      }
    }
    if (rings > 0) std::sort(out.begin(), out.end());
    return out;
  }

  // Tries the vertices of a and b in order; moves the first whose move towards the centroid
  // of its neighbours lowers the crossings around the pair.
  bool move_one_vertex_of(std::uint32_t a, std::uint32_t b) {
    const std::vector<std::uint32_t> region = around_pair(a, b);
    // The region's boxes, once for the six vertices: a try puts its vertex back unless it is
    // kept (the last try).
    std::vector<Box>& boxes = scratch_region_boxes_;
    boxes.resize(region.size());
    for (std::size_t k = 0; k < region.size(); ++k) boxes[k] = box(region[k]);
    for (const std::uint32_t f : {a, b}) {
      const Mesh::Triangle t = mesh_.triangles[f];
      for (const std::uint32_t v : t) {
        if (try_move(v, region, boxes)) return true;
      }
    }
    return false;
  }

  // Intersecting pairs of a triangle of `faces` (sorted) with a triangle of `others` (each
  // pair once).
  [[nodiscard]] std::size_t crossings_around(const std::vector<std::uint32_t>& faces,
                                             const std::vector<std::uint32_t>& others,
                                             const std::vector<Box>& other_boxes, std::size_t stop = SIZE_MAX) const {
    // Which of `others` are among `faces`, with their boxes as they are now (they moved with
    // the fan or patch), once per call rather than per pair: mine[k] is 1 + the index of
    // others[k]'s box in moved, or 0.
    std::vector<Box>& moved = scratch_boxes_;
    std::vector<std::uint32_t>& mine = scratch_mine_;
    moved.clear();
    mine.assign(others.size(), 0);
    for (std::size_t k = 0; k < others.size(); ++k) {
      if (std::binary_search(faces.begin(), faces.end(), others[k])) {
        moved.push_back(box(others[k]));
        mine[k] = static_cast<std::uint32_t>(moved.size());
      }
    }
    std::size_t n = 0;
    for (const std::uint32_t f : faces) {
      if (n >= stop) break;
      const Box bf = box(f);
      for (std::size_t k = 0; k < others.size(); ++k) {
        const std::uint32_t g = others[k];
        if (g == f || !alive(g)) continue;
        if (mine[k] && g < f) continue;  // counted from g
        if (!overlap(bf, mine[k] ? moved[mine[k] - 1] : other_boxes[k])) continue;
        if (intersect(f, g)) ++n;
      }
    }
    return n;
  }

  bool try_move(std::uint32_t v, const std::vector<std::uint32_t>& region, const std::vector<Box>& region_boxes) {
    const double limit = v < max_move_.size() ? max_move_[v] : 0.0;
    if (!(limit > 0)) return false;
    const auto here = around(v);
    std::vector<std::uint32_t> faces(here.begin(), here.end());
    std::sort(faces.begin(), faces.end());
    glm::dvec3 centroid(0);
    std::size_t count = 0;
    for (const std::uint32_t f : faces) {
      for (const std::uint32_t w : mesh_.triangles[f]) {
        if (w == v) continue;
        centroid += mesh_.positions[w];  // each neighbour twice on a closed mesh: same mean
        ++count;
      }
    }
    if (count == 0) return false;
    centroid /= double(count);
    const glm::dvec3 old = mesh_.positions[v];
    const glm::dvec3 origin = origin_.try_emplace(v, old).first->second;
    std::vector<glm::dvec3> facing(faces.size());
    for (std::size_t i = 0; i < faces.size(); ++i) facing[i] = mesh_.face_normal(mesh_.triangles[faces[i]]);
    // Only the region's triangles near the fan around v, wherever v moves within the limit.
    Box reach = box(faces);
    const double travel = glm::length(old - origin) + limit;  // farthest v can get from here
    reach = {reach.first - glm::dvec3(travel), reach.second + glm::dvec3(travel)};
    // Boxes of the fan's own triangles change with v; they are recomputed in the count.
    std::vector<std::uint32_t> near;
    std::vector<Box> near_boxes;
    for (std::size_t k = 0; k < region.size(); ++k) {
      if (overlap(reach, region_boxes[k])) {
        near.push_back(region[k]);
        near_boxes.push_back(region_boxes[k]);
      }
    }
    const std::size_t before = crossings_around(faces, near, near_boxes);
    // Nor may the move carry the fan across a skeleton node, as collapses and refills may not
    // (samples x particle seeds 1-3: one more node inside, small_pine seed 2).
    const std::vector<std::size_t> kept = kept_within(reach);
    const std::vector<Mesh::Triangle> fan = fan_triangles(faces);
    glm::dvec3 outward(0);
    for (const auto& n : facing) outward += n;
    const double olen = glm::length(outward);
    if (olen > 0) outward /= olen;
    std::vector<glm::dvec3> targets;
    auto towards_axis = [&] {
      if (v >= axis_point_.size()) return;
      const glm::dvec3 in = axis_point_[v] - old;
      const double l = glm::length(in);
      if (!(l > 0)) return;
      for (const double k : {0.5, 1.0}) targets.push_back(old + std::min(k * limit, 0.5 * l) * (in / l));
    };
    if (axis_targets_ == AxisTargets::first) towards_axis();
    for (const double lambda : {1.0, 0.5, 0.25}) targets.push_back(old + lambda * (centroid - old));
    // Then along the fan's normal, out and in: a vertex poking through a neighbouring strip
    // is often pushed back by that rather than by smoothing. (Pairs on callistemon /
    // small_pine / agraf, particle seeds 1, 2, 3: 3,978 in all without these targets, 3,622
    // with them; 130 -> 36 on callistemon, but small_pine seed 1 847 -> 900.)
    for (const double k : {1.0, -1.0, 0.5, -0.5}) targets.push_back(old + k * limit * outward);
    if (axis_targets_ == AxisTargets::last) towards_axis();
    for (glm::dvec3 target : targets) {
      // The limit holds for the total move from where stitching put v.
      const glm::dvec3 offset = target - origin;
      const double len = glm::length(offset);
      if (len > limit) target = origin + offset * (limit / len);
      if (!(glm::length(target - old) > 0)) continue;
      set_vertex(v, target);
      bool ok = true;
      for (std::size_t i = 0; i < faces.size() && ok; ++i) {
        ok = glm::dot(mesh_.face_normal(mesh_.triangles[faces[i]]), facing[i]) > 0;
      }
      if (ok && crossings_around(faces, near, near_boxes, before) < before && !crosses_kept(kept, fan, fan, v, old)) {
        moved_.insert(moved_.end(), faces.begin(), faces.end());
        return true;
      }
    }
    set_vertex(v, old);
    return false;
  }

  [[nodiscard]] bool alive(std::uint32_t f) const { return dead_.empty() || !dead_[f]; }
  // Every change to the mesh goes through these, so the undo log holds each triangle's and
  // vertex's value from before the repair.
  void record_triangle(std::uint32_t f) {
    if (undo_ && undo_->triangle_seen.insert(f).second) undo_->triangles.emplace_back(f, mesh_.triangles[f]);
  }
  void set_triangle(std::uint32_t f, const Mesh::Triangle& t) {
    record_triangle(f);
    mesh_.triangles[f] = t;
  }
  void set_vertex(std::uint32_t v, const glm::dvec3& p) {
    if (undo_ && undo_->position_seen.insert(v).second) undo_->positions.emplace_back(v, mesh_.positions[v]);
    mesh_.positions[v] = grid_ > 0 ? snap_to_grid(p, grid_) : p;
  }
  // The exact test of two triangles, counted against the budget.
  [[nodiscard]] bool intersect(std::uint32_t f, std::uint32_t g) const {
    ++tests_;
    return test_.intersect(f, g);
  }

  // The keep_side points within `bounds`, with their winding numbers about `faces` (the
  // solid angles the triangles span, over 4 pi; Van Oosterom and Strackee's formula).
  // Replacing a patch by another with the same boundary carries the surface across a point
  // exactly when the two numbers differ by one.
  // (In increasing index. Found among the points sorted by x, made on the first call: the scan
  // of every skeleton node per attempted move showed as about 14 ms of the large grown tree's
  // repair in a profile.)
  [[nodiscard]] std::vector<std::size_t> kept_within(const Box& bounds) const {
    if (keep_by_x_.size() != keep_side_.size()) {
      keep_by_x_.resize(keep_side_.size());
      std::iota(keep_by_x_.begin(), keep_by_x_.end(), std::uint32_t{0});
      std::sort(keep_by_x_.begin(), keep_by_x_.end(), [&](std::uint32_t a, std::uint32_t b) {
        return keep_side_[a].x != keep_side_[b].x ? keep_side_[a].x < keep_side_[b].x : a < b;
      });
    }
    auto x_of = [&](std::uint32_t i) { return keep_side_[i].x; };
    const auto from = std::lower_bound(keep_by_x_.begin(), keep_by_x_.end(), bounds.first.x,
                                       [&](std::uint32_t i, double x) { return x_of(i) < x; });
    std::vector<std::size_t> out;
    for (auto it = from; it != keep_by_x_.end() && x_of(*it) <= bounds.second.x; ++it) {
      const glm::dvec3& p = keep_side_[*it];
      if (glm::all(glm::lessThanEqual(bounds.first, p)) && glm::all(glm::lessThanEqual(p, bounds.second)))
        out.push_back(*it);
    }
    std::sort(out.begin(), out.end());
    return out;
  }
  // The triangles `faces` as they are now.
  [[nodiscard]] std::vector<Mesh::Triangle> fan_triangles(const std::vector<std::uint32_t>& faces) const {
    std::vector<Mesh::Triangle> out;
    for (const std::uint32_t f : faces) out.push_back(mesh_.triangles[f]);
    return out;
  }

  // Winding numbers of the keep_side `points` about the triangles `tris`, with vertex
  // `moved` (if any) at `at` instead of where it is.
  [[nodiscard]] std::vector<double> windings(const std::vector<std::size_t>& points,
                                             const std::vector<Mesh::Triangle>& tris, std::uint32_t moved = UINT32_MAX,
                                             const glm::dvec3& at = {}) const {
    auto position = [&](std::uint32_t v) { return v == moved ? at : mesh_.positions[v]; };
    std::vector<double> w(points.size(), 0.0);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const glm::dvec3& p = keep_side_[points[i]];
      for (const auto& t : tris) w[i] += solid_angle(position(t[0]) - p, position(t[1]) - p, position(t[2]) - p);
      w[i] /= 4.0 * std::numbers::pi;
    }
    return w;
  }
  // Whether replacing the triangles `before` (with vertex `moved` at `at`) by `after` (as the
  // mesh is now) carries the surface across one of the keep_side `points`.
  [[nodiscard]] bool crosses_kept(const std::vector<std::size_t>& points, const std::vector<Mesh::Triangle>& before,
                                  const std::vector<Mesh::Triangle>& after, std::uint32_t moved = UINT32_MAX,
                                  const glm::dvec3& at = {}) const {
    if (points.empty()) return false;
    const std::vector<double> w0 = windings(points, before, moved, at), w1 = windings(points, after);
    for (std::size_t i = 0; i < points.size(); ++i) {
      if (std::abs(w1[i] - w0[i]) > 0.5) return true;
    }
    return false;
  }
  [[nodiscard]] bool movable(std::uint32_t v) const { return v < max_move_.size() && max_move_[v] > 0; }

  // Tries the edges of triangles a and b and of the triangles sharing a vertex with them, in
  // order; makes the first collapse that lowers the number of intersections around the pair.
  bool collapse_one_edge_of(std::uint32_t a, std::uint32_t b) {
    const std::vector<std::uint32_t> region = around_pair(a, b);
    // The crossing pairs of the region, found once: an edge is only tried when triangles
    // around it take part in one.
    std::vector<Box> boxes(region.size());
    for (std::size_t i = 0; i < region.size(); ++i) boxes[i] = box(region[i]);
    std::vector<std::array<std::uint32_t, 2>> crossing;
    for (std::size_t i = 0; i < region.size(); ++i) {
      if (!alive(region[i])) continue;
      for (std::size_t j = i + 1; j < region.size(); ++j) {
        if (alive(region[j]) && overlap(boxes[i], boxes[j]) && intersect(region[i], region[j]))
          crossing.push_back({region[i], region[j]});
      }
    }
    // The edges of a, b and the triangles sharing a vertex with them, each once.
    std::vector<std::array<std::uint32_t, 3>> edges;  // (f, u, w) with u < w
    for (const std::uint32_t f : within_rings({a, b}, 1)) {
      const Mesh::Triangle& t = mesh_.triangles[f];
      for (int e = 0; e < 3; ++e) {
        const std::uint32_t u = t[std::size_t(e)], w = t[std::size_t((e + 1) % 3)];
        if (u < w) edges.push_back({f, u, w});
      }
    }
    for (const auto& [f, u, w] : edges) {
      if (alive(f) && try_collapse(f, u, w, region, crossing)) return true;
    }
    return false;
  }

  // Replaces the triangles of `patch` (sorted), when they form a disk, by CGAL's
  // triangulation of the disk's boundary loop, if that lowers the crossings of the disk with
  // itself and with the triangles within two rings around it. The disk's inner vertices go;
  // the new triangles take the first slots of the old ones, the other slots die.
  bool refill(const std::vector<std::uint32_t>& patch) {
    // Directed edges; the boundary ones have no twin in the patch.
    std::vector<std::array<std::uint32_t, 2>> directed;
    std::vector<std::uint32_t> verts;
    for (const std::uint32_t f : patch) {
      const auto& t = mesh_.triangles[f];
      for (int k = 0; k < 3; ++k) {
        directed.push_back({t[std::size_t(k)], t[std::size_t((k + 1) % 3)]});
        verts.push_back(t[std::size_t(k)]);
      }
    }
    std::sort(directed.begin(), directed.end());
    if (std::adjacent_find(directed.begin(), directed.end()) != directed.end()) return false;
    std::sort(verts.begin(), verts.end());
    verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
    std::vector<std::array<std::uint32_t, 2>> boundary;
    for (const auto& [u, v] : directed) {
      if (!std::binary_search(directed.begin(), directed.end(), std::array<std::uint32_t, 2>{v, u}))
        boundary.push_back({u, v});
    }
    const std::size_t edges = (directed.size() + boundary.size()) / 2;
    // A disk: Euler characteristic 1 and one boundary loop through distinct vertices.
    if (verts.size() + patch.size() != edges + 1 || boundary.size() < 3) return false;
    for (std::size_t i = 1; i < boundary.size(); ++i) {
      if (boundary[i][0] == boundary[i - 1][0]) return false;  // a vertex the loop passes twice
    }
    auto next = [&](std::uint32_t u) {
      const auto it = std::lower_bound(boundary.begin(), boundary.end(), std::array<std::uint32_t, 2>{u, 0});
      return it != boundary.end() && (*it)[0] == u ? (*it)[1] : UINT32_MAX;
    };
    std::vector<std::uint32_t> loop{boundary[0][0]};
    for (std::uint32_t v = next(loop[0]); v != loop[0]; v = next(v)) {
      if (v == UINT32_MAX || loop.size() >= boundary.size()) return false;
      loop.push_back(v);
    }
    if (loop.size() != boundary.size()) return false;  // several loops
    const std::size_t n = loop.size();
    if (n > kMaxRefillLoop) return false;

    std::vector<glm::dvec3> points(n), outside(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t u = loop[i], v = loop[(i + 1) % n];
      points[i] = mesh_.positions[u];
      // The triangle across the boundary edge (u, v) has the edge (v, u).
      std::uint32_t across_uv = UINT32_MAX;
      for (const std::uint32_t g : around(u)) {
        const auto& t = mesh_.triangles[g];
        for (int k = 0; k < 3; ++k) {
          if (t[std::size_t(k)] == v && t[std::size_t((k + 1) % 3)] == u) across_uv = g;
        }
      }
      if (across_uv == UINT32_MAX) return false;
      outside[i] = mesh_.positions[third(mesh_.triangles[across_uv], u, v)];
    }
    // The patch's surroundings: its crossings with them are counted before and after.
    std::vector<std::uint32_t> around_patch = within_rings(patch, 2), others;
    std::vector<Box> other_boxes;
    for (const std::uint32_t g : around_patch) {
      if (!alive(g)) continue;
      others.push_back(g);
      other_boxes.push_back(box(g));
    }
    // A patch refused before, with everything around it as it was then, is refused again
    // without the search (O(n^3) in its boundary): later rounds meet the same pairs.
    std::uint64_t key = 1469598103934665603ull;  // FNV-1a over triangles, corners and positions
    auto mix = [&](std::uint64_t x) { key = (key ^ x) * 1099511628211ull; };
    auto mix_faces = [&](const std::vector<std::uint32_t>& faces) {
      for (const std::uint32_t f : faces) {
        mix(f);
        for (const std::uint32_t v : mesh_.triangles[f]) {
          mix(v);
          for (int k = 0; k < 3; ++k) mix(std::bit_cast<std::uint64_t>(mesh_.positions[v][k]));
        }
      }
    };
    mix_faces(patch);
    mix_faces(others);
    if (refused_.count(key)) return false;
    refused_.insert(key);  // erased again below if the refill is made
    std::vector<std::array<std::uint32_t, 3>> fill = triangulate_polyline(points, outside);
    if (fill.empty()) return false;  // otherwise n - 2 triangles
    for (const auto& t : fill) {
      if (sliver({loop[t[0]], loop[t[1]], loop[t[2]]})) return false;
    }
    // Orient the fill like the patch: the boundary edges (loop[i], loop[i + 1]) keep their direction.
    std::vector<std::array<std::uint32_t, 2>> fill_directed;
    for (auto& t : fill) {
      for (std::uint32_t& i : t) i = loop[i];
    }
    auto directed_of = [&] {
      fill_directed.clear();
      for (const auto& t : fill) {
        for (int k = 0; k < 3; ++k) fill_directed.push_back({t[std::size_t(k)], t[std::size_t((k + 1) % 3)]});
      }
      std::sort(fill_directed.begin(), fill_directed.end());
    };
    directed_of();
    if (!std::binary_search(fill_directed.begin(), fill_directed.end(), boundary[0])) {
      for (auto& t : fill) std::swap(t[1], t[2]);
      directed_of();
    }
    if (std::adjacent_find(fill_directed.begin(), fill_directed.end()) != fill_directed.end()) return false;
    for (const auto& [u, v] : fill_directed) {
      const bool on_boundary = std::binary_search(boundary.begin(), boundary.end(), std::array<std::uint32_t, 2>{u, v});
      if (on_boundary) continue;
      // An inner edge needs its twin in the fill, and must not be an edge outside the patch.
      if (!std::binary_search(fill_directed.begin(), fill_directed.end(), std::array<std::uint32_t, 2>{v, u}))
        return false;
      for (const std::uint32_t g : around(u)) {
        if (std::binary_search(patch.begin(), patch.end(), g)) continue;
        const auto& t = mesh_.triangles[g];
        if (t[0] == v || t[1] == v || t[2] == v) return false;
      }
    }
    for (const auto& e : boundary) {
      if (!std::binary_search(fill_directed.begin(), fill_directed.end(), e)) return false;
    }

    const std::size_t before = crossings_around(patch, others, other_boxes);
    if (before == 0) return false;
    const std::vector<std::size_t> kept = kept_within(box(patch));
    const std::vector<Mesh::Triangle> saved = fan_triangles(patch);
    dead_.resize(mesh_.triangles.size(), 0);
    for (std::size_t i = 0; i < patch.size(); ++i) {
      if (i < fill.size()) {
        set_triangle(patch[i], fill[i]);
      } else {
        dead_[patch[i]] = 1;
      }
    }
    const std::vector<std::uint32_t> filled(patch.begin(), patch.begin() + std::ptrdiff_t(fill.size()));
    if (crossings_around(filled, others, other_boxes, before) >= before || crosses_kept(kept, saved, fill)) {
      for (std::size_t i = 0; i < patch.size(); ++i) {
        set_triangle(patch[i], saved[i]);
        dead_[patch[i]] = 0;
      }
      return false;
    }
    for (std::size_t i = fill.size(); i < patch.size(); ++i) {
      const std::uint32_t x = saved[i][0];
      set_triangle(patch[i], Mesh::Triangle{x, x, x});
    }
    for (const std::uint32_t v : verts) {
      std::vector<std::uint32_t>& list = changed(v);
      std::erase_if(list, [&](std::uint32_t g) { return std::binary_search(patch.begin(), patch.end(), g); });
      for (const std::uint32_t g : filled) {
        const auto& t = mesh_.triangles[g];
        if (t[0] == v || t[1] == v || t[2] == v) list.push_back(g);
      }
    }
    moved_.insert(moved_.end(), filled.begin(), filled.end());
    refused_.erase(key);
    return true;
  }

  // The vertices sharing an edge with v, sorted.
  [[nodiscard]] std::vector<std::uint32_t> neighbours(std::uint32_t v) const {
    std::vector<std::uint32_t> out;
    for (const std::uint32_t g : around(v)) {
      for (const std::uint32_t w : mesh_.triangles[g]) {
        if (w != v) out.push_back(w);
      }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
    return out;
  }

  // Collapses the edge (u, w) of triangle f1 into u, placed midway, at u or at w (the first
  // that lowers the crossings among `region`; `crossing` holds the region's crossing pairs),
  // when that keeps the mesh a closed 2-manifold of the same genus (the link condition: u and
  // w share exactly the two neighbours across the edge) and turns no triangle over. Both
  // vertices must be movable (max_move > 0), but the collapse is not bounded by max_move: the
  // kept vertex stays on the old edge, and the edges worth collapsing are often long spikes
  // of a fold (up to 25 radii on callistemon; bounding the collapse to 2 radii left 518 pairs
  // on the samples x seeds 1-3 instead of 475, fidelity p95 the same). The two triangles of
  // the edge die: they become degenerate (u, u, u), out of every vertex's list, and the
  // caller drops them.
  bool try_collapse(std::uint32_t f1, std::uint32_t u, std::uint32_t w, const std::vector<std::uint32_t>& region,
                    const std::vector<std::array<std::uint32_t, 2>>& crossing) {
    const std::uint32_t f2 = across(f1, u, w);
    if (f2 == UINT32_MAX) return false;
    const std::uint32_t c = third(mesh_.triangles[f1], u, w), d = third(mesh_.triangles[f2], u, w);
    if (c == d || c == UINT32_MAX || d == UINT32_MAX) return false;
    if (!movable(u) || !movable(w)) return false;
    // The triangles that survive around u and w (each once: only f1 and f2 have both).
    std::vector<std::uint32_t> fan;
    for (const std::uint32_t v : {u, w}) {
      for (const std::uint32_t g : around(v)) {
        if (g != f1 && g != f2) fan.push_back(g);
      }
    }
    std::sort(fan.begin(), fan.end());
    fan.erase(std::unique(fan.begin(), fan.end()), fan.end());
    std::vector<std::uint32_t> faces = fan;
    faces.push_back(f1);
    faces.push_back(f2);
    std::sort(faces.begin(), faces.end());
    const std::size_t before =
        static_cast<std::size_t>(std::count_if(crossing.begin(), crossing.end(), [&](const auto& pq) {
          return std::binary_search(faces.begin(), faces.end(), pq[0]) ||
                 std::binary_search(faces.begin(), faces.end(), pq[1]);
        }));
    if (before == 0) return false;
    // Only edges whose own triangles cross something: collapsing removes them. (Trying every
    // edge around the pair found a few more repairs at many times the cost.)
    if (std::none_of(crossing.begin(), crossing.end(),
                     [&](const auto& pq) { return pq[0] == f1 || pq[1] == f1 || pq[0] == f2 || pq[1] == f2; }))
      return false;
    {
      const std::vector<std::uint32_t> nu = neighbours(u), nw = neighbours(w);
      std::vector<std::uint32_t> common;
      std::set_intersection(nu.begin(), nu.end(), nw.begin(), nw.end(), std::back_inserter(common));
      if (common.size() != 2) return false;
      // A tetrahedron-like neighbourhood (valence 3) would collapse onto itself.
      if (nu.size() <= 3 || nw.size() <= 3) return false;
    }

    const glm::dvec3 pu = mesh_.positions[u], pw = mesh_.positions[w];
    std::vector<glm::dvec3> facing(fan.size());
    for (std::size_t i = 0; i < fan.size(); ++i) facing[i] = mesh_.face_normal(mesh_.triangles[fan[i]]);
    const Box reach = box(faces);
    std::vector<std::uint32_t> near;
    std::vector<Box> near_boxes;
    for (const std::uint32_t g : region) {
      if (!alive(g)) continue;
      const Box b = box(g);
      if (overlap(reach, b)) {
        near.push_back(g);
        near_boxes.push_back(b);
      }
    }

    const std::vector<std::size_t> kept = kept_within(reach);
    const std::vector<Mesh::Triangle> old_faces = fan_triangles(faces);
    // Rewire: w -> u in the fan; f1 and f2 die.
    const std::vector<Mesh::Triangle> saved = fan_triangles(fan);
    for (const std::uint32_t g : fan) {
      record_triangle(g);
      for (std::uint32_t& x : mesh_.triangles[g]) {
        if (x == w) x = u;
      }
    }
    dead_.resize(mesh_.triangles.size(), 0);
    dead_[f1] = dead_[f2] = 1;
    // The target box `near` was taken with the fan where it was: the fan stays inside it
    // (each target lies on the segment between u and w).
    for (const glm::dvec3& target : {0.5 * (pu + pw), pu, pw}) {
      set_vertex(u, target);
      bool ok = true;
      for (std::size_t i = 0; i < fan.size() && ok; ++i) {
        ok = glm::dot(mesh_.face_normal(mesh_.triangles[fan[i]]), facing[i]) > 0 && !sliver(mesh_.triangles[fan[i]]);
      }
      if (ok && crossings_around(fan, near, near_boxes, before) < before &&
          !crosses_kept(kept, old_faces, fan_triangles(fan), u, pu)) {
        set_triangle(f1, Mesh::Triangle{u, u, u});
        set_triangle(f2, Mesh::Triangle{u, u, u});
        origin_.try_emplace(u, pu);  // later moves stay bounded from where stitching put u
        std::vector<std::uint32_t>& at_u = changed(u);
        at_u = fan;
        changed(w).clear();
        std::erase(changed(c), f1);
        std::erase(changed(d), f2);
        moved_.insert(moved_.end(), fan.begin(), fan.end());
        return true;
      }
    }
    for (std::size_t i = 0; i < fan.size(); ++i) set_triangle(fan[i], saved[i]);
    dead_[f1] = dead_[f2] = 0;
    set_vertex(u, pu);
    return false;
  }

  // The other triangle with the directed edge (v, u), or UINT32_MAX.
  [[nodiscard]] std::uint32_t across(std::uint32_t f, std::uint32_t u, std::uint32_t v) const {
    for (const std::uint32_t g : around(u)) {
      if (g == f) continue;
      const auto& t = mesh_.triangles[g];
      for (int k = 0; k < 3; ++k) {
        if (t[std::size_t(k)] == v && t[std::size_t((k + 1) % 3)] == u) return g;
      }
    }
    return UINT32_MAX;
  }

  // across(f, u, v), first looking at the triangles stitched just before and after f (a
  // strip's neighbours: two of a strip triangle's three), where the edge v -> u is found
  // without searching u's triangles. On a manifold mesh one triangle holds that edge, so the
  // answer is the same.
  [[nodiscard]] std::uint32_t across_near(std::uint32_t f, std::uint32_t u, std::uint32_t v) const {
    auto holds = [&](std::uint32_t g) {
      const auto& t = mesh_.triangles[g];
      return (t[0] == v && t[1] == u) || (t[1] == v && t[2] == u) || (t[2] == v && t[0] == u);
    };
    if (f > 0 && holds(f - 1)) return f - 1;
    if (f + 1 < mesh_.triangles.size() && holds(f + 1)) return f + 1;
    return across(f, u, v);
  }

  [[nodiscard]] static std::uint32_t third(const Mesh::Triangle& t, std::uint32_t u, std::uint32_t v) {
    for (const std::uint32_t w : t) {
      if (w != u && w != v) return w;
    }
    return UINT32_MAX;
  }

  // A sliver or worse: area below kSliver x its longest edge squared (collapses and refills
  // must not make one; the mesh checks count near-zero areas as degenerate).
  [[nodiscard]] bool sliver(const Mesh::Triangle& t) const {
    const glm::dvec3 &p = mesh_.positions[t[0]], &q = mesh_.positions[t[1]], &r = mesh_.positions[t[2]];
    auto squared = [](const glm::dvec3& v) { return glm::dot(v, v); };
    const double longest = std::max({squared(q - p), squared(r - q), squared(p - r)});
    return !(glm::length(glm::cross(q - p, r - p)) > kSliver * longest);
  }

  // The intersecting pairs among `region` that involve f1 or f2 (the others do not change
  // when f1 and f2 are flipped).
  [[nodiscard]] Box box(std::uint32_t f) const {
    const auto& t = mesh_.triangles[f];
    const glm::dvec3 &p = mesh_.positions[t[0]], &q = mesh_.positions[t[1]], &r = mesh_.positions[t[2]];
    return {glm::min(p, glm::min(q, r)), glm::max(p, glm::max(q, r))};
  }
  // The box around the triangles `faces` (not empty).
  [[nodiscard]] Box box(const std::vector<std::uint32_t>& faces) const {
    Box out = box(faces.front());
    for (const std::uint32_t f : faces) {
      const Box b = box(f);
      out = {glm::min(out.first, b.first), glm::max(out.second, b.second)};
    }
    return out;
  }
  [[nodiscard]] static bool overlap(const Box& x, const Box& y) {
    return glm::all(glm::lessThanEqual(x.first, y.second)) && glm::all(glm::lessThanEqual(y.first, x.second));
  }

  // Counting stops at `stop` (the caller only asks whether it stays below that).
  // `boxes` are the region's triangles' boxes (those of f1 and f2 are not used).
  [[nodiscard]] std::size_t crossings(std::uint32_t f1, std::uint32_t f2, const std::vector<std::uint32_t>& region,
                                      const std::vector<Box>& boxes, std::size_t stop = SIZE_MAX) const {
    const auto b1 = box(f1), b2 = box(f2);
    std::size_t n = overlap(b1, b2) && intersect(f1, f2) ? 1 : 0;
    for (std::size_t k = 0; k < region.size(); ++k) {
      if (n >= stop) break;
      const std::uint32_t g = region[k];
      if (g == f1 || g == f2 || !alive(g)) continue;
      if (overlap(b1, boxes[k]) && intersect(f1, g)) ++n;
      if (overlap(b2, boxes[k]) && intersect(f2, g)) ++n;
    }
    return n;
  }

  // Flips the edge (a, b) of triangle f1 if that lowers the crossings among `region`.
  bool try_flip(std::uint32_t f1, std::uint32_t a, std::uint32_t b, const std::vector<std::uint32_t>& region,
                const std::vector<Box>& boxes) {
    const std::uint32_t f2 = across(f1, a, b);
    if (f2 == UINT32_MAX) return false;
    const std::uint32_t c = third(mesh_.triangles[f1], a, b), d = third(mesh_.triangles[f2], a, b);
    if (c == d || c == UINT32_MAX || d == UINT32_MAX) return false;
    for (const std::uint32_t g : around(c)) {
      const auto& t = mesh_.triangles[g];
      if (t[0] == d || t[1] == d || t[2] == d) return false;  // (c, d) is an edge already
    }
    const Mesh::Triangle old1 = mesh_.triangles[f1], old2 = mesh_.triangles[f2];
    const glm::dvec3 facing = mesh_.face_normal(old1) + mesh_.face_normal(old2);
    // (a, b, c) and (b, a, d) become (a, d, c) and (d, b, c): the outline a d b c is kept.
    const Mesh::Triangle new1{a, d, c}, new2{d, b, c};
    const glm::dvec3 n1 = mesh_.face_normal(new1), n2 = mesh_.face_normal(new2);
    if (!(glm::dot(n1, facing) > 0) || !(glm::dot(n2, facing) > 0)) return false;

    const std::size_t before = crossings(f1, f2, region, boxes);
    set_triangle(f1, new1);
    set_triangle(f2, new2);
    if (crossings(f1, f2, region, boxes, before) >= before) {
      set_triangle(f1, old1);
      set_triangle(f2, old2);
      return false;
    }
    // a leaves f2, b leaves f1, c joins f2, d joins f1.
    flipped_.push_back(f1);
    flipped_.push_back(f2);
    std::erase(changed(a), f2);
    std::erase(changed(b), f1);
    changed(c).push_back(f2);
    changed(d).push_back(f1);
    return true;
  }

  Mesh& mesh_;
  const std::vector<std::uint8_t>& suspect_;
  const std::vector<double>& max_move_;
  bool collapse_;
  bool refill_;
  std::size_t max_pairs_;
  std::size_t max_tests_;
  mutable std::size_t tests_ = 0;  // exact triangle-pair tests made
  std::span<const glm::dvec3> keep_side_;
  mutable std::vector<Box> scratch_boxes_;          // crossings_around's
  std::vector<Box> scratch_region_boxes_;           // flip_one_edge_of's and move_one_vertex_of's
  mutable std::vector<std::uint32_t> scratch_mine_;  // crossings_around's
  mutable std::vector<std::uint32_t> vertex_mark_, triangle_mark_;  // within_rings's, by stamp
  mutable std::uint32_t stamp_ = 0;
  mutable std::vector<std::uint32_t> keep_by_x_;    // keep_side_'s indices by x (kept_within)
  std::span<const glm::dvec3> axis_point_;
  AxisTargets axis_targets_;
  double grid_;
  FoldRepairUndo* undo_;
  std::map<std::uint32_t, glm::dvec3> origin_;  // where stitching put the vertices tried for moves
  std::vector<std::uint32_t> moved_;            // the triangles around the vertices moved in this round
  std::vector<std::uint32_t> flipped_;          // the triangles flipped in this round (two per flip)
  TriangleIntersections test_;
  std::vector<std::uint32_t> around_begin_;  // #V + 1 offsets into around_flat_
  std::vector<std::uint32_t> around_flat_;
  static constexpr std::uint32_t kUnchanged = UINT32_MAX;
  std::vector<std::uint32_t> changed_slot_;               // #V: the vertex's list in changed_lists_, or kUnchanged
  std::deque<std::vector<std::uint32_t>> changed_lists_;  // of the vertices whose triangles a flip changed
  std::unordered_set<std::uint64_t> refused_;                    // patches (with surroundings) a refill was refused for
  std::vector<std::uint8_t> dead_;  // #F once an edge was collapsed: the triangles it removed
};

}  // namespace

FoldRepairStats repair_folds(Mesh& mesh, const std::vector<std::uint8_t>& suspect, const std::vector<double>& max_move,
                             const FoldRepairOptions& options, FoldRepairUndo* undo) {
  if (options.max_rounds <= 0 || std::find(suspect.begin(), suspect.end(), 1) == suspect.end()) return {};
  return FoldRepair(mesh, suspect, max_move, options, undo).run(options.max_rounds);
}

}  // namespace sm
