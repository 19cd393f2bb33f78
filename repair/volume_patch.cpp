// Volume patch (see volume_patch.h). Kept in its own translation unit: OpenVDB's headers are
// heavy to compile.
#include "repair/volume_patch.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <numeric>
#include <unordered_map>
#include <tuple>
#include <utility>

#include <openvdb/openvdb.h>
#include <tbb/parallel_for.h>
#include <openvdb/tools/VolumeToMesh.h>

#include "core/math.h"
#include "core/union_find.h"
#include "meshcheck/intersections.h"
#include "skeleton/skeleton.h"

namespace sm {
namespace {

using glm::dvec3;
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();

struct Box {
  dvec3 lo{std::numeric_limits<double>::max()}, hi{std::numeric_limits<double>::lowest()};
  void add(const dvec3& p) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  void add(const Box& b) {
    lo = glm::min(lo, b.lo);
    hi = glm::max(hi, b.hi);
  }
  [[nodiscard]] Box grown(double d) const { return {lo - dvec3(d), hi + dvec3(d)}; }
  [[nodiscard]] bool contains(const dvec3& p) const {
    return p.x >= lo.x && p.y >= lo.y && p.z >= lo.z && p.x <= hi.x && p.y <= hi.y && p.z <= hi.z;
  }
  [[nodiscard]] bool overlaps(const Box& b) const {
    return lo.x <= b.hi.x && lo.y <= b.hi.y && lo.z <= b.hi.z && b.lo.x <= hi.x && b.lo.y <= hi.y && b.lo.z <= hi.z;
  }
};


// Triangles binned by centroid on a uniform grid, for box queries.
class TriangleBins {
 public:
  TriangleBins(const Mesh& mesh) : mesh_(mesh) {
    Box all;
    for (const dvec3& p : mesh.positions) all.add(p);
    for (const auto& t : mesh.triangles) {
      Box b;
      for (const std::uint32_t v : t) b.add(mesh.positions[v]);
      reach_ = std::max(reach_, glm::length(b.hi - b.lo));
    }
    const dvec3 size = all.hi - all.lo;
    cell_ = std::max({reach_, std::cbrt(size.x * size.y * size.z / std::max<double>(1, mesh.triangles.size())) * 4,
                      1e-9});
    lo_ = all.lo;
    for (std::uint32_t f = 0; f < mesh.triangles.size(); ++f) bins_[key(cell_of(centroid(f)))].push_back(f);
  }
  // Every triangle that may reach into `box` (by its centroid and the largest triangle's size), in order.
  [[nodiscard]] std::vector<std::uint32_t> near(const Box& box) const {
    const Box b = box.grown(reach_);
    const glm::ivec3 a = cell_of(b.lo), z = cell_of(b.hi);
    std::vector<std::uint32_t> out;
    for (int i = a.x; i <= z.x; ++i)
      for (int j = a.y; j <= z.y; ++j)
        for (int k = a.z; k <= z.z; ++k) {
          const auto it = bins_.find(key({i, j, k}));
          if (it == bins_.end()) continue;
          for (const std::uint32_t f : it->second)
            if (b.contains(centroid(f))) out.push_back(f);
        }
    std::sort(out.begin(), out.end());
    return out;
  }

 private:
  [[nodiscard]] dvec3 centroid(std::uint32_t f) const {
    const auto& t = mesh_.triangles[f];
    return (mesh_.positions[t[0]] + mesh_.positions[t[1]] + mesh_.positions[t[2]]) / 3.0;
  }
  [[nodiscard]] glm::ivec3 cell_of(const dvec3& p) const { return glm::ivec3(glm::floor((p - lo_) / cell_)); }
  static std::uint64_t key(const glm::ivec3& c) {
    return (static_cast<std::uint64_t>(c.x + (1 << 20)) << 42) | (static_cast<std::uint64_t>(c.y + (1 << 20)) << 21) |
           static_cast<std::uint64_t>(c.z + (1 << 20));
  }
  const Mesh& mesh_;
  double reach_ = 0, cell_ = 1;
  dvec3 lo_{0};
  std::unordered_map<std::uint64_t, std::vector<std::uint32_t>> bins_;
};

// One cluster of pairs and, once built, its patch.
struct Patch {
  Box region;                           // triangles wholly inside are cut out
  double radius_min = 0, radius_max = 0;
  bool node = false;                    // holds the region of an uncovered node
  std::vector<std::uint32_t> cut;       // the triangles cut out, sorted
  std::vector<glm::dvec3> positions;    // the patch's vertices (snapped)
  std::vector<std::uint32_t> vertex_origin;    // per patch vertex: nearest mesh triangle
  std::vector<glm::dvec3> vertex_closest;      // per patch vertex: nearest point on it
  // Triangles over mesh vertices (index < nv) and patch vertices (nv + k).
  std::vector<Mesh::Triangle> triangles;
  std::vector<std::uint32_t> replaced;  // kept triangles on split hole edges, replaced by fans
  std::vector<std::pair<Mesh::Triangle, std::uint32_t>> fans;  // those fans' triangles, with their origin
  std::size_t voxels = 0;
  std::string failure;
};

// A closed loop of boundary half-edges: `next[a] = b` for each edge a -> b. Fails where a
// vertex has two outgoing edges.
bool boundary_loops(const std::vector<std::array<std::uint32_t, 2>>& edges, std::vector<std::vector<std::uint32_t>>& loops) {
  std::map<std::uint32_t, std::uint32_t> next;
  for (const auto& [a, b] : edges) {
    if (!next.emplace(a, b).second) return false;
  }
  std::map<std::uint32_t, bool> used;
  for (const auto& [start, ignored] : next) {
    if (used[start]) continue;
    std::vector<std::uint32_t> loop;
    std::uint32_t v = start;
    while (!used[v]) {
      used[v] = true;
      loop.push_back(v);
      const auto it = next.find(v);
      if (it == next.end()) return false;
      v = it->second;
    }
    if (v != start || loop.size() < 3) return false;
    loops.push_back(std::move(loop));
  }
  return true;
}


class Builder {
 public:
  Builder(const Mesh& mesh, const VertexCorners& vc, const Skeleton& skeleton, const VolumePatchOptions& options)
      : mesh_(mesh), vc_(vc), skeleton_(skeleton), options_(options) {}

  // The triangles across each edge: opposite[3 f + k] is the triangle on edge (t[k], t[k+1]).
  void link() {
    seen_.assign(mesh_.triangles.size(), 0);
    opposite_.assign(3 * mesh_.triangles.size(), kNone);
    for (std::uint32_t f = 0; f < mesh_.triangles.size(); ++f) {
      const auto& t = mesh_.triangles[f];
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = t[k], b = t[(k + 1) % 3];
        for (std::uint32_t c = vc_.begin[b]; c < vc_.begin[b + 1]; ++c) {
          const std::uint32_t g = vc_.corner[c] / 3, kk = vc_.corner[c] % 3;
          if (mesh_.triangles[g][(kk + 1) % 3] == a) opposite_[3 * f + k] = g;
        }
      }
    }
  }

  // The triangle with edge b -> a (across the edge a -> b).
  [[nodiscard]] std::uint32_t opposite_of(std::uint32_t a, std::uint32_t b) const {
    for (std::uint32_t c = vc_.begin[b]; c < vc_.begin[b + 1]; ++c) {
      const std::uint32_t g = vc_.corner[c] / 3, k = vc_.corner[c] % 3;
      if (mesh_.triangles[g][(k + 1) % 3] == a) return g;
    }
    return kNone;
  }

  void build(Patch& patch, const TriangleBins& bins) {
    const Box& region = patch.region;
    // The cut: the surface inside the region's box is replaced. phi < 0 inside the box; the
    // triangles across its faces are split where phi, interpolated along their edges, is 0,
    // and the patch is split there too, so that both end on the same curves.
    const dvec3 mid = 0.5 * (region.lo + region.hi), half = 0.5 * (region.hi - region.lo);
    auto phi = [&](const dvec3& p) {
      const dvec3 d = glm::abs(p - mid) - half;
      return std::max({d.x, d.y, d.z});
    };
    // Where phi is 0 on the segment pu - pw (linearly between its ends), on the float grid.
    auto zero_on = [&](const dvec3& pu, const dvec3& pw) {
      const double fu = phi(pu), fw = phi(pw);
      const dvec3 q = pu + (pw - pu) * std::clamp(fu / (fu - fw), 0.0, 1.0);
      return options_.grid > 0 ? snap_to_grid(q, options_.grid) : q;
    };
    const auto nv = static_cast<std::uint32_t>(mesh_.positions.size());
    auto at_pos = [&](std::uint32_t v) { return v < nv ? mesh_.positions[v] : patch.positions[v - nv]; };
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> mesh_cut_point;
    auto cut_point = [&](std::uint32_t u, std::uint32_t w, std::uint32_t f) {
      const auto key = std::make_pair(std::min(u, w), std::max(u, w));
      if (const auto it = mesh_cut_point.find(key); it != mesh_cut_point.end()) return it->second;
      const dvec3 q = zero_on(mesh_.positions[key.first], mesh_.positions[key.second]);
      const auto id = nv + static_cast<std::uint32_t>(patch.positions.size());
      patch.positions.push_back(q);
      patch.vertex_origin.push_back(f);
      patch.vertex_closest.push_back(q);
      mesh_cut_point.emplace(key, id);
      return id;
    };
    // Hole edges in the direction the patch must run along them (against the kept part's).
    std::vector<std::array<std::uint32_t, 2>> hole_edges;
    for (const std::uint32_t f : bins.near(region.grown(1e-9))) {
      const auto& t = mesh_.triangles[f];
      const bool in[3] = {phi(mesh_.positions[t[0]]) < 0, phi(mesh_.positions[t[1]]) < 0, phi(mesh_.positions[t[2]]) < 0};
      const int count = in[0] + in[1] + in[2];
      if (count == 0) continue;
      if (count == 3) {
        patch.cut.push_back(f);
        continue;
      }
      patch.replaced.push_back(f);
      // Rotate so that corner 0 is the odd one out.
      int o = 0;
      for (int k = 0; k < 3; ++k)
        if ((count == 1) == in[k]) o = k;
      const std::uint32_t a = t[o], b = t[(o + 1) % 3], c = t[(o + 2) % 3];
      const std::uint32_t ab = cut_point(a, b, f), ca = cut_point(c, a, f);
      if (count == 2) {  // a outside: the kept part is the triangle at a
        patch.fans.push_back({{a, ab, ca}, f});
        hole_edges.push_back({ca, ab});
      } else {  // a inside: the kept part is the quad b, c, ca, ab
        patch.fans.push_back({{ab, b, c}, f});
        patch.fans.push_back({{ab, c, ca}, f});
        hole_edges.push_back({ab, ca});
      }
    }
    std::sort(patch.cut.begin(), patch.cut.end());
    std::vector<std::vector<std::uint32_t>> holes;
    if (!boundary_loops(hole_edges, holes)) {
      patch.failure = "the region's boundary crosses the surface in touching loops";
      return;
    }
    if (patch.cut.empty() && patch.replaced.empty()) {  // (a node's region the surface misses)
      patch.failure = "the region holds no surface";
      return;
    }
    // The scale: the thinnest branch of the pairs (thinner ones passing the region and lost on
    // the grid leave a hole without a rim, and the patch is not made).
    const double rmin = std::max(patch.radius_min, 1e-5);

    // The grid: the region and a margin of three voxels.
    double h = rmin / options_.voxels_per_radius;
    const dvec3 size = region.hi - region.lo;
    auto count = [&](double s) {
      return (std::floor(size.x / s) + 8) * (std::floor(size.y / s) + 8) * (std::floor(size.z / s) + 8);
    };
    while (count(h) > static_cast<double>(options_.max_voxels)) h *= 1.1;
    // Twigs thinner than a voxel or so vanish from the grid, and where the box cuts one its hole
    // has no rim: inside the patch they are drawn thicker instead (a local, bounded error), as
    // long as the region's thickest branch of the pairs is still resolved.
    const double floor_r = options_.min_twig_voxels * h;
    if (floor_r > 0 ? std::max(patch.radius_max, rmin) / h < options_.min_voxels_per_radius
                    : rmin / h < options_.min_voxels_per_radius) {
      patch.failure = floor_r > 0 ? "the region is too large for its branches" : "the region is too large for its thinnest branch";
      return;
    }
    const double band = 4 * h;
    const dvec3 origin = region.lo - dvec3(4 * h);
    const glm::ivec3 n = glm::ivec3(glm::floor(size / h)) + glm::ivec3(9);
    const std::size_t nvox = static_cast<std::size_t>(n.x) * n.y * n.z;
    patch.voxels = nvox;
    auto at = [&](int i, int j, int k) { return (static_cast<std::size_t>(k) * n.y + j) * n.x + i; };
    auto centre = [&](int i, int j, int k) { return origin + h * dvec3(i, j, k); };
    std::vector<float> dist(nvox, static_cast<float>(band));
    std::vector<std::uint32_t> nearest(nvox, kNone);
    Box grid_box{origin, origin + h * dvec3(n - glm::ivec3(1))};
    // The cut surface's distance is read only where the field blends into it (within three
    // voxels of the box's faces, below): only that shell of the grid is filled.
    const double shell = -3 * h;
    const double x_low_end = mid.x - half.x - shell, x_high_start = mid.x + half.x + shell;
    std::vector<std::uint32_t> local;  // triangles reaching into the grid
    for (const std::uint32_t f : bins.near(grid_box)) {
      const auto& t = mesh_.triangles[f];
      const dvec3 &a = mesh_.positions[t[0]], &b = mesh_.positions[t[1]], &c = mesh_.positions[t[2]];
      Box tb;
      tb.add(a);
      tb.add(b);
      tb.add(c);
      tb = tb.grown(band);
      if (!tb.overlaps(grid_box)) continue;
      local.push_back(f);
      const glm::ivec3 lo = glm::max(glm::ivec3(glm::ceil((tb.lo - origin) / h)), glm::ivec3(0));
      const glm::ivec3 hi = glm::min(glm::ivec3(glm::floor((tb.hi - origin) / h)), n - glm::ivec3(1));
      // Only voxels within the band of the triangle's plane can come nearer than the band (a
      // coarse triangle in a fine grid: a slab of its box, not the box). The margin keeps
      // every voxel whose distance, rounded, could still be under the band.
      const dvec3 normal = glm::cross(b - a, c - a);
      const double area2 = glm::length(normal);
      const dvec3 unit = area2 > 0 ? normal / area2 : dvec3(0);
      const double slab = band * (1 + 1e-6) + 1e-12;
      for (int k = lo.z; k <= hi.z; ++k)
        for (int j = lo.y; j <= hi.y; ++j) {
          const dvec3 row = centre(0, j, k);
          const bool row_in_shell = std::max(std::abs(row.y - mid.y) - half.y, std::abs(row.z - mid.z) - half.z) > shell;
          // Off the y and z faces only the ends of the row near the x faces are in the shell.
          const int skip_from = row_in_shell ? hi.x + 1 : static_cast<int>(std::floor((x_low_end - origin.x) / h)) + 1;
          const int skip_to = row_in_shell ? hi.x + 1 : static_cast<int>(std::ceil((x_high_start - origin.x) / h)) - 1;
          // The row's voxels within the slab: the plane's distance is linear in i.
          int first = lo.x, last = hi.x;
          if (area2 > 0) {
            const double d0 = glm::dot(row - a, unit), step = h * unit.x;
            if (std::abs(step) > 1e-12 * h) {
              // (Clamped to the row before the conversion: a plane nearly along x puts them
              // far beyond any int.)
              const double u = (-slab - d0) / step, w = (slab - d0) / step;
              const double row_lo = lo.x - 1.0, row_hi = hi.x + 1.0;
              first = std::max(first, static_cast<int>(std::floor(std::clamp(std::min(u, w), row_lo, row_hi))));
              last = std::min(last, static_cast<int>(std::ceil(std::clamp(std::max(u, w), row_lo, row_hi))));
            } else if (std::abs(d0) > slab) {
              continue;
            }
          }
          for (int i = first; i <= last; ++i) {
            if (i > skip_from && i < skip_to) i = skip_to;
            const dvec3 p = centre(i, j, k);
            if (phi(p) <= shell) continue;
            const auto d = static_cast<float>(glm::distance(p, closest_on_triangle(p, a, b, c)));
            const std::size_t v = at(i, j, k);
            if (d < dist[v]) {
              dist[v] = d;
              nearest[v] = f;
            }
          }
        }
    }
    // Triangles binned on the grid, for the nearest cut triangle of a point (below).
    const int bin = 2;  // voxels per bin side
    const glm::ivec3 nb = (n + glm::ivec3(bin - 1)) / bin;
    std::vector<std::vector<std::uint32_t>> bins_of(static_cast<std::size_t>(nb.x) * nb.y * nb.z);
    for (const std::uint32_t f : local) {
      const auto& t = mesh_.triangles[f];
      Box tb;
      for (const std::uint32_t v : t) tb.add(mesh_.positions[v]);
      const glm::ivec3 lo = glm::clamp(glm::ivec3(glm::floor((tb.lo - origin) / (h * bin))), glm::ivec3(0), nb - glm::ivec3(1));
      const glm::ivec3 hi = glm::clamp(glm::ivec3(glm::floor((tb.hi - origin) / (h * bin))), glm::ivec3(0), nb - glm::ivec3(1));
      for (int k = lo.z; k <= hi.z; ++k)
        for (int j = lo.y; j <= hi.y; ++j)
          for (int i = lo.x; i <= hi.x; ++i) bins_of[(static_cast<std::size_t>(k) * nb.y + j) * nb.x + i].push_back(f);
    }
    // The triangle of the grid nearest p within `reach` (kNone if none), and its nearest point:
    // rings of bins outward, until the next ring is farther than the best so far, each
    // triangle once (a large one lies in many bins); of equal distances the lowest index.
    struct Near {
      std::uint32_t f = kNone;
      dvec3 q{0.0};
    };
    auto nearest_in_bins = [&](const dvec3& p, double reach) {
      ++query_;
      const glm::ivec3 c = glm::ivec3(glm::floor((p - origin) / (h * bin)));
      const int cells = static_cast<int>(std::ceil(reach / (h * bin)));
      double best = reach;
      Near found;
      for (int r = 0; r <= cells && best > (r - 1) * h * bin; ++r)
        for (int z = std::max(c.z - r, 0); z <= std::min(c.z + r, nb.z - 1); ++z)
          for (int y = std::max(c.y - r, 0); y <= std::min(c.y + r, nb.y - 1); ++y)
            for (int x = std::max(c.x - r, 0); x <= std::min(c.x + r, nb.x - 1); ++x) {
              if (std::max({std::abs(x - c.x), std::abs(y - c.y), std::abs(z - c.z)}) != r) continue;
              for (const std::uint32_t f : bins_of[(static_cast<std::size_t>(z) * nb.y + y) * nb.x + x]) {
                if (seen_[f] == query_) continue;
                seen_[f] = query_;
                const auto& t = mesh_.triangles[f];
                const dvec3 q = closest_on_triangle(p, mesh_.positions[t[0]], mesh_.positions[t[1]], mesh_.positions[t[2]]);
                const double d = glm::distance(p, q);
                if (d < best || (d == best && found.f != kNone && f < found.f)) {
                  best = d;
                  found = {f, q};
                }
              }
            }
      return found;
    };
    // The cut triangle nearest a voxel's centre within the band: read from the shell where it
    // was filled, searched in the bins elsewhere (once per voxel).
    std::unordered_map<std::size_t, std::uint32_t> nearest_found;
    auto nearest_to = [&](const dvec3& q) {
      const glm::ivec3 g = glm::clamp(glm::ivec3(glm::round((q - origin) / h)), glm::ivec3(0), n - glm::ivec3(1));
      const std::size_t v = at(g.x, g.y, g.z);
      const dvec3 p = centre(g.x, g.y, g.z);
      if (phi(p) > shell) return nearest[v];
      return nearest_found.try_emplace(v, nearest_in_bins(p, band).f).first->second;
    };
    // The solid: inside the region, the union of the skeleton's round cones (the input is the
    // truth, and the surface there is what could not be judged); near the kept surface, which
    // is clean, the surface's own signed distance (signed by its nearest triangle), blended
    // into the cones over two voxels so that the patch meets it.
    struct Cone {
      dvec3 a, b;
      double ra, rb;
    };
    std::vector<Cone> cones;
    // The input's edges: nodes the sanitizing inserted (binary forks, clusters of laterals)
    // are skipped, each input node joined to its nearest input ancestor.
    const bool has_source = skeleton_.source_id.size() == skeleton_.position.size();
    auto from_input = [&](std::size_t i) { return !has_source || skeleton_.source_id[i] >= 0; };
    for (std::size_t c = 0; c < skeleton_.position.size(); ++c) {
      if (!skeleton_.parent[c].valid() || !from_input(c)) continue;
      NodeId first = NodeId(static_cast<std::uint32_t>(c)), up = skeleton_.parent[c];
      while (up.valid() && !from_input(up.idx())) {
        first = up;
        up = skeleton_.parent[up.idx()];
      }
      if (!up.valid()) continue;
      const double start = first.idx() == c ? skeleton_.start_radius(first) : skeleton_.radius[up.idx()];
      const Cone cone{skeleton_.position[up.idx()], skeleton_.position[c], std::max(start, floor_r),
                      std::max(skeleton_.radius[c], floor_r)};
      Box cb;
      cb.add(cone.a);
      cb.add(cone.b);
      if (cb.grown(std::max(cone.ra, cone.rb) + band).overlaps(grid_box)) cones.push_back(cone);
    }
    // The cones' distance, each over its own box only (the rest of the grid is farther than
    // the band from it), in slices in parallel (a minimum: the same for any order).
    std::vector<float> cone_field(nvox, static_cast<float>(band));
    // The twigs drawn thicker, also where the field blends into the cut surface (so that their
    // rims reach the box's faces).
    std::vector<float> twig_field(floor_r > 0 ? nvox : 0, static_cast<float>(band));
    for (const Cone& c : cones) {
      const bool twig = floor_r > 0 && std::min(c.ra, c.rb) <= floor_r;
      Box cb;
      cb.add(c.a);
      cb.add(c.b);
      cb = cb.grown(std::max(c.ra, c.rb) + band);
      const glm::ivec3 lo = glm::max(glm::ivec3(glm::ceil((cb.lo - origin) / h)), glm::ivec3(0));
      const glm::ivec3 hi = glm::min(glm::ivec3(glm::floor((cb.hi - origin) / h)), n - glm::ivec3(1));
      if (lo.x > hi.x || lo.y > hi.y || lo.z > hi.z) continue;
      tbb::parallel_for(lo.z, hi.z + 1, [&](int k) {
        for (int j = lo.y; j <= hi.y; ++j)
          for (int i = lo.x; i <= hi.x; ++i) {
            const dvec3 p = centre(i, j, k);
            const double t = segment_param(p, c.a, c.b);
            const auto d = static_cast<float>(glm::distance(p, c.a + t * (c.b - c.a)) - (c.ra + t * (c.rb - c.ra)));
            float& f = cone_field[at(i, j, k)];
            f = std::min(f, d);
            if (twig) twig_field[at(i, j, k)] = std::min(twig_field[at(i, j, k)], d);
          }
      });
    }
    std::vector<float> field(nvox);
    tbb::parallel_for(0, n.z, [&](int k) {
      for (int j = 0; j < n.y; ++j)
        for (int i = 0; i < n.x; ++i) {
          const std::size_t v = at(i, j, k);
          const dvec3 p = centre(i, j, k);
          const double w = std::clamp((phi(p) + 3 * h) / (2 * h), 0.0, 1.0);
          double fm = band;
          if (w > 0 && nearest[v] != kNone) {
            const auto& t = mesh_.triangles[nearest[v]];
            const dvec3 q = closest_on_triangle(p, mesh_.positions[t[0]], mesh_.positions[t[1]], mesh_.positions[t[2]]);
            fm = glm::dot(p - q, mesh_.face_normal(t)) > 0 ? dist[v] : -dist[v];
          }
          double value = w * fm + (1 - w) * static_cast<double>(cone_field[v]);
          if (!twig_field.empty()) value = std::min(value, static_cast<double>(twig_field[v]));
          field[v] = static_cast<float>(std::clamp(value, -band, band));
        }
    });
    openvdb::initialize();
    openvdb::FloatGrid::Ptr grid = openvdb::FloatGrid::create(static_cast<float>(band));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(h));
    grid->setGridClass(openvdb::GRID_LEVEL_SET);
    {
      auto acc = grid->getAccessor();
      for (int k = 0; k < n.z; ++k)
        for (int j = 0; j < n.y; ++j)
          for (int i = 0; i < n.x; ++i) {
            const float value = field[at(i, j, k)];
            if (value < static_cast<float>(band)) acc.setValue(openvdb::Coord(i, j, k), value);
          }
    }
    std::vector<openvdb::Vec3s> points;
    std::vector<openvdb::Vec3I> tris;
    std::vector<openvdb::Vec4I> quads;
    openvdb::tools::volumeToMesh(*grid, points, tris, quads, 0.0, 0.0, true);

    // The volume's surface on the float grid, points at one position welded (the mesher can
    // place two at one spot, and the grid can round two together): a triangle left with two
    // corners at one vertex is an edge collapsed, dropped.
    std::vector<dvec3> pos;
    std::vector<std::uint32_t> weld(points.size());
    {
      std::map<std::tuple<double, double, double>, std::uint32_t> at_point;
      for (std::size_t i = 0; i < points.size(); ++i) {
        dvec3 q = origin + dvec3(points[i].x(), points[i].y(), points[i].z());
        if (options_.grid > 0) q = snap_to_grid(q, options_.grid);
        const auto [it, fresh] = at_point.try_emplace({q.x, q.y, q.z}, static_cast<std::uint32_t>(pos.size()));
        if (fresh) pos.push_back(q);
        weld[i] = it->second;
      }
    }
    std::vector<Mesh::Triangle> iso;
    auto add_iso = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
      const Mesh::Triangle t{weld[a], weld[b], weld[c]};
      if (t[0] != t[1] && t[1] != t[2] && t[2] != t[0]) iso.push_back(t);
    };
    for (const auto& t : tris) add_iso(t.x(), t.y(), t.z());
    for (const auto& q : quads) {
      const dvec3 px = pos[weld[q.x()]], py = pos[weld[q.y()]], pz = pos[weld[q.z()]], pw = pos[weld[q.w()]];
      if (glm::distance(px, pz) <= glm::distance(py, pw)) {
        add_iso(q.x(), q.y(), q.z());
        add_iso(q.x(), q.z(), q.w());
      } else {
        add_iso(q.x(), q.y(), q.w());
        add_iso(q.y(), q.z(), q.w());
      }
    }
    // Orientation: most triangles must face down the level set's slope (outward).
    double facing = 0;
    for (const auto& t : iso) {
      const dvec3 c = (pos[t[0]] + pos[t[1]] + pos[t[2]]) / 3.0;
      const glm::ivec3 g = glm::clamp(glm::ivec3(glm::round((c - origin) / h)), glm::ivec3(1), n - glm::ivec3(2));
      auto value = [&](int i, int j, int k) {
        return static_cast<double>(field[at(i, j, k)]);
      };
      const dvec3 grad(value(g.x + 1, g.y, g.z) - value(g.x - 1, g.y, g.z),
                       value(g.x, g.y + 1, g.z) - value(g.x, g.y - 1, g.z),
                       value(g.x, g.y, g.z + 1) - value(g.x, g.y, g.z - 1));
      facing += glm::dot(glm::cross(pos[t[1]] - pos[t[0]], pos[t[2]] - pos[t[0]]), grad) > 0 ? 1 : -1;
    }
    if (facing < 0)
      for (auto& t : iso) std::swap(t[1], t[2]);

    // The patch: the volume's surface inside the box, split along phi = 0 like the mesh.
    std::vector<std::uint32_t> index(pos.size(), kNone);
    // Per patch vertex from here on, the point whose nearest cut triangle becomes its origin:
    // looked up only once the rims have matched the holes (most builds that fail, fail there).
    std::vector<dvec3> origin_of;
    auto add = [&](std::uint32_t u) {
      if (index[u] != kNone) return index[u];
      index[u] = nv + static_cast<std::uint32_t>(patch.positions.size());
      const dvec3 p = options_.grid > 0 ? snap_to_grid(pos[u], options_.grid) : pos[u];
      patch.positions.push_back(p);
      origin_of.push_back(pos[u]);
      return index[u];
    };
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> iso_cut_point;
    auto iso_cut = [&](std::uint32_t u, std::uint32_t x) {
      const auto key = std::make_pair(std::min(u, x), std::max(u, x));
      if (const auto it = iso_cut_point.find(key); it != iso_cut_point.end()) return it->second;
      const dvec3 q = zero_on(pos[key.first], pos[key.second]);
      const auto id = nv + static_cast<std::uint32_t>(patch.positions.size());
      patch.positions.push_back(q);
      origin_of.push_back(q);
      iso_cut_point.emplace(key, id);
      return id;
    };
    std::vector<std::uint8_t> inside(pos.size());
    for (std::size_t i = 0; i < pos.size(); ++i) inside[i] = phi(pos[i]) < 0;
    std::vector<Mesh::Triangle> kept;  // in patch numbering
    std::vector<std::array<std::uint32_t, 2>> rim_edges;
    for (const auto& t : iso) {
      const int corners_in = inside[t[0]] + inside[t[1]] + inside[t[2]];
      if (corners_in == 0) continue;
      if (corners_in == 3) {
        kept.push_back({add(t[0]), add(t[1]), add(t[2])});
        continue;
      }
      int o = 0;
      for (int k = 0; k < 3; ++k)
        if ((corners_in == 1) == static_cast<bool>(inside[t[k]])) o = k;
      const std::uint32_t a = t[o], b = t[(o + 1) % 3], c = t[(o + 2) % 3];
      const std::uint32_t ab = iso_cut(a, b), ca = iso_cut(c, a);
      if (corners_in == 1) {  // a inside
        kept.push_back({add(a), ab, ca});
        rim_edges.push_back({ab, ca});
      } else {  // a outside: the quad b, c, ca, ab
        kept.push_back({ab, add(b), add(c)});
        kept.push_back({ab, add(c), ca});
        rim_edges.push_back({ca, ab});
      }
    }
    // Parts of the patch without a rim (lumps inside the box) are dropped.
    const std::size_t np = nv + patch.positions.size();
    UnionFind parts(np);
    for (const auto& t : kept) {
      parts.unite(t[0], t[1]);
      parts.unite(t[1], t[2]);
    }
    std::vector<std::vector<std::uint32_t>> rims;
    if (!boundary_loops(rim_edges, rims)) {
      patch.failure = "the volume's surface crosses the box in touching loops";
      return;
    }
    // Each hole to the rim nearest it on average, one to one; parts of the volume's surface
    // whose rims meet no hole (bits of branches passing the box's edge) are dropped.
    std::vector<std::size_t> rim_of(holes.size(), kNone);
    std::vector<std::uint8_t> rim_used(rims.size(), 0);
    for (std::size_t a = 0; a < holes.size(); ++a) {
      double best = std::numeric_limits<double>::max();
      for (std::size_t b = 0; b < rims.size(); ++b) {
        double sum = 0;
        for (const std::uint32_t v : holes[a]) {
          double d = std::numeric_limits<double>::max();
          for (const std::uint32_t u : rims[b]) d = std::min(d, glm::distance(at_pos(v), at_pos(u)));
          sum += d;
        }
        if (sum / holes[a].size() < best) {
          best = sum / holes[a].size();
          rim_of[a] = b;
        }
      }
      if (rim_of[a] == kNone || rim_used[rim_of[a]] || best > 3 * h) {
        patch.failure = "a hole has no rim of its own near it";
        return;
      }
      rim_used[rim_of[a]] = 1;
    }
    {
      std::vector<std::uint8_t> matched_part(np, 0);
      for (std::size_t b = 0; b < rims.size(); ++b)
        if (rim_used[b]) matched_part[parts.find(rims[b][0])] = 1;
      for (std::size_t b = 0; b < rims.size(); ++b) {
        if (!rim_used[b] && matched_part[parts.find(rims[b][0])]) {
          patch.failure = "a part of the volume's surface has a rim that meets no hole";
          return;
        }
      }
      std::erase_if(kept, [&](const Mesh::Triangle& t) { return !matched_part[parts.find(t[0])]; });
    }
    for (std::size_t k = 0; k < origin_of.size(); ++k) {
      std::uint32_t f = nearest_to(origin_of[k]);
      if (f == kNone) f = patch.cut.empty() ? patch.replaced.front() : patch.cut.front();
      const auto& t = mesh_.triangles[f];
      patch.vertex_origin.push_back(f);
      patch.vertex_closest.push_back(
          closest_on_triangle(origin_of[k], mesh_.positions[t[0]], mesh_.positions[t[1]], mesh_.positions[t[2]]));
    }
    patch.triangles = kept;
    // Near the holes the cut surface is clean and is the solid's boundary: the patch's vertices
    // there go onto it (the nearest point of a cut triangle), so that patch and kept surface
    // meet as one sheet instead of two a voxel apart.
    {
      const double reach_band = 3 * h;
      for (std::size_t k = 0; k < patch.positions.size(); ++k) {
        const dvec3 p = patch.positions[k];
        if (phi(p) < -reach_band) continue;
        dvec3 onto = p;
        if (const Near near = nearest_in_bins(p, reach_band); near.f != kNone) {
          // Only onto a triangle's inside: points nearest an edge or corner would land on one
          // another.
          const auto& t = mesh_.triangles[near.f];
          const dvec3 w = barycentric(mesh_.positions[t[0]], mesh_.positions[t[1]], mesh_.positions[t[2]], near.q);
          if (std::min({w.x, w.y, w.z}) > 1e-3) onto = near.q;
        }
        patch.positions[k] = options_.grid > 0 ? snap_to_grid(onto, options_.grid) : onto;
      }
    }
    // The zipper: each rim is laid onto its hole. Rim vertices move to their nearest points on
    // the hole (kept in order along it, one onto a hole vertex where that is within a tenth
    // of a voxel), and each side's edges take the other side's vertices that fall on them
    // (the triangle on such an edge becomes a fan from its third corner). Patch and kept
    // surface then share their boundary, vertex for vertex.
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> on_edge;  // by directed edge
    std::map<std::uint32_t, std::uint32_t> rename;  // rim vertex -> hole vertex it became
    for (std::size_t a = 0; a < holes.size(); ++a) {
      const std::vector<std::uint32_t>& hole = holes[a];
      const std::vector<std::uint32_t>& rim = rims[rim_of[a]];
      const std::size_t nh = hole.size(), nr = rim.size();
      std::vector<double> at_s(nh + 1, 0.0);
      for (std::size_t i = 0; i < nh; ++i) at_s[i + 1] = at_s[i] + glm::distance(at_pos(hole[i]), at_pos(hole[(i + 1) % nh]));
      const double length = at_s[nh];
      auto project = [&](const dvec3& q) {
        double best = std::numeric_limits<double>::max(), param = 0;
        for (std::size_t i = 0; i < nh; ++i) {
          const dvec3 u = at_pos(hole[i]), w = at_pos(hole[(i + 1) % nh]);
          const double t = segment_param(q, u, w);
          const double d = glm::distance(q, u + t * (w - u));
          if (d < best) {
            best = d;
            param = at_s[i] + t * (at_s[i + 1] - at_s[i]);
          }
        }
        return param;
      };
      auto point_at = [&](double param) {
        param = std::fmod(param, length);
        if (param < 0) param += length;
        const std::size_t i = std::min<std::size_t>(
            static_cast<std::size_t>(std::upper_bound(at_s.begin(), at_s.end(), param) - at_s.begin()) - 1, nh - 1);
        const double seg = at_s[i + 1] - at_s[i];
        const double t = seg > 0 ? (param - at_s[i]) / seg : 0.0;
        return std::make_pair(i, t);
      };
      // Parameters along the hole, unwrapped to increase once around from the rim vertex nearest its start.
      std::vector<double> param(nr);
      for (std::size_t j = 0; j < nr; ++j) param[j] = project(at_pos(rim[j]));
      std::size_t first = 0;
      for (std::size_t j = 1; j < nr; ++j) {
        if (std::min(param[j], length - param[j]) < std::min(param[first], length - param[first])) first = j;
      }
      std::vector<double> unwrapped(nr);
      double prev = param[first] > length / 2 ? param[first] - length : param[first];
      const double min_step = 1e-3 * h;
      for (std::size_t k = 0; k < nr; ++k) {
        double x = param[(first + k) % nr];
        while (x < prev - length / 2) x += length;
        while (x > prev + length / 2) x -= length;
        if (k > 0) x = std::max(x, prev + min_step);
        unwrapped[k] = x;
        prev = x;
      }
      const double start = unwrapped[0];
      if (unwrapped[nr - 1] > start + length - min_step || unwrapped[nr - 1] < start + 0.5 * length) {
        patch.failure = "a rim does not run once around its hole";
        return;
      }
      // Rim vertices onto the hole: moved, or renamed to a hole vertex nearby (at most one each).
      const double snap = 0.1 * h;
      struct Mark {
        double s;
        std::uint32_t v;
        bool hole, rim;
      };
      std::vector<Mark> merged;  // along the hole
      for (std::size_t i = 0; i < nh; ++i) {
        double x = at_s[i];
        while (x < start) x += length;
        while (x >= start + length) x -= length;
        merged.push_back({x, hole[i], true, false});
      }
      std::stable_sort(merged.begin(), merged.end(), [](const Mark& x, const Mark& y) { return x.s < y.s; });
      std::map<std::uint32_t, std::size_t> mark_of;
      for (std::size_t k = 0; k < merged.size(); ++k) mark_of[merged[k].v] = k;
      std::vector<Mark> moved;
      for (std::size_t k = 0; k < nr; ++k) {
        const std::uint32_t r = rim[(first + k) % nr];
        const auto [i, t] = point_at(unwrapped[k]);
        const double d0 = t * (at_s[i + 1] - at_s[i]), d1 = (1 - t) * (at_s[i + 1] - at_s[i]);
        const std::uint32_t near_hole = d0 <= d1 ? hole[i] : hole[(i + 1) % nh];
        Mark& m = merged[mark_of[near_hole]];
        // Renamed only where that keeps the rim's order along the hole.
        const bool in_order = (k == 0 || unwrapped[k - 1] < m.s) && (k + 1 == nr || m.s < unwrapped[k + 1]) &&
                              m.s >= start && m.s < start + length;
        if (std::min(d0, d1) <= snap && !m.rim && in_order && std::abs(m.s - unwrapped[k]) <= snap) {
          rename[r] = near_hole;
          m.rim = true;
          continue;
        }
        const dvec3 u = at_pos(hole[i]), w = at_pos(hole[(i + 1) % nh]);
        dvec3 q = u + t * (w - u);
        if (options_.grid > 0) q = snap_to_grid(q, options_.grid);
        // A rim vertex that would land on the one before it stays where it is (off the hole
        // by less than a voxel; the fans take it there).
        if (moved.empty() || glm::distance(q, patch.positions[moved.back().v - nv]) >= 0.05 * h)
          patch.positions[r - nv] = q;
        moved.push_back({unwrapped[k], r, false, true});
      }
      merged.insert(merged.end(), moved.begin(), moved.end());
      std::stable_sort(merged.begin(), merged.end(), [](const Mark& x, const Mark& y) { return x.s < y.s; });
      // Each side's edges and the other side's vertices between their ends.
      const std::size_t nm = merged.size();
      for (int side = 0; side < 2; ++side) {
        // side 0: hole edges take rim vertices; side 1: rim edges take hole vertices.
        auto mine = [&](const Mark& m) { return side == 0 ? m.hole : m.rim; };
        std::size_t k0 = kNone;
        for (std::size_t k = 0; k < nm && k0 == kNone; ++k)
          if (mine(merged[k])) k0 = k;
        if (k0 == kNone) continue;
        std::uint32_t from = merged[k0].v;
        std::vector<std::uint32_t> between;
        for (std::size_t step = 1; step <= nm; ++step) {
          const Mark& m = merged[(k0 + step) % nm];
          if (mine(m)) {
            if (!between.empty()) on_edge[{from, m.v}] = between;
            between.clear();
            from = m.v;
          } else {
            between.push_back(m.v);
          }
        }
      }
    }
    // Renamed rim vertices in the patch's triangles.
    for (auto& t : patch.triangles)
      for (std::uint32_t& v : t)
        if (const auto it = rename.find(v); it != rename.end()) v = it->second;
    // Rim edges are walked with renamed ends too.
    {
      std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> renamed;
      for (auto& [e, list] : on_edge) {
        auto r = [&](std::uint32_t v) {
          const auto it = rename.find(v);
          return it == rename.end() ? v : it->second;
        };
        renamed[{r(e.first), r(e.second)}] = list;
      }
      on_edge = std::move(renamed);
    }
    // Fans: the patch's triangles on an edge (a, b) in the free direction, and the kept
    // surface's on (b, a), take the points listed for it.
    auto refan = [&](std::vector<Mesh::Triangle>& list, std::vector<std::uint32_t>* origins, bool kept_side) {
      std::vector<Mesh::Triangle> out;
      std::vector<std::uint32_t> out_origin;
      for (std::size_t f = 0; f < list.size(); ++f) {
        const auto& t = list[f];
        std::vector<std::uint32_t> ring;
        int split = 0, where = 0;
        for (int k = 0; k < 3; ++k) {
          ring.push_back(t[k]);
          const std::uint32_t u = t[k], w = t[(k + 1) % 3];
          const auto it = kept_side ? on_edge.find({w, u}) : on_edge.find({u, w});
          if (it == on_edge.end()) continue;
          ++split;
          where = k;
          if (kept_side) {
            ring.insert(ring.end(), it->second.rbegin(), it->second.rend());
          } else {
            ring.insert(ring.end(), it->second.begin(), it->second.end());
          }
        }
        const std::uint32_t o = origins ? (*origins)[f] : kNone;
        if (split == 0) {
          out.push_back(t);
          out_origin.push_back(o);
          continue;
        }
        if (split > 1) {  // two of its edges on the rim: fan from a point inside
          dvec3 c(0.0);
          for (const std::uint32_t v : t) c += at_pos(v);
          c /= 3.0;
          if (options_.grid > 0) c = snap_to_grid(c, options_.grid);
          const auto id = nv + static_cast<std::uint32_t>(patch.positions.size());
          patch.positions.push_back(c);
          patch.vertex_origin.push_back(patch.vertex_origin[(t[0] >= nv ? t[0] : t[1] >= nv ? t[1] : t[2]) - nv]);
          patch.vertex_closest.push_back(c);
          for (std::size_t k = 0; k < ring.size(); ++k) {
            out.push_back({id, ring[k], ring[(k + 1) % ring.size()]});
            out_origin.push_back(o);
          }
          continue;
        }
        const std::uint32_t apex = t[(where + 2) % 3];
        const auto from = static_cast<std::size_t>(std::find(ring.begin(), ring.end(), apex) - ring.begin());
        for (std::size_t k = 1; k + 1 < ring.size(); ++k) {
          out.push_back({apex, ring[(from + k) % ring.size()], ring[(from + k + 1) % ring.size()]});
          out_origin.push_back(o);
        }
      }
      list = std::move(out);
      if (origins) *origins = std::move(out_origin);
    };
    refan(patch.triangles, nullptr, false);
    {
      std::vector<Mesh::Triangle> kt;
      std::vector<std::uint32_t> ko;
      for (const auto& [t, o] : patch.fans) {
        kt.push_back(t);
        ko.push_back(o);
      }
      refan(kt, &ko, true);
      patch.fans.clear();
      for (std::size_t f = 0; f < kt.size(); ++f) patch.fans.push_back({kt[f], ko[f]});
    }
    // Vertices the zipper or the projection put at one position are one vertex (the edge
    // between them collapsed; a triangle left with two corners at one vertex goes).
    {
      std::map<std::tuple<double, double, double>, std::uint32_t> at_point;
      std::map<std::uint32_t, std::uint32_t> same;
      auto visit = [&](std::uint32_t v) {
        const dvec3 q = at_pos(v);
        const auto [it, fresh] = at_point.try_emplace({q.x, q.y, q.z}, v);
        if (!fresh && it->second != v) {
          // The mesh's own vertex, else the first seen, stands for the position.
          if (v < nv && it->second >= nv) {
            same[it->second] = v;
            it->second = v;
          } else {
            same[v] = it->second;
          }
        }
      };
      for (const auto& t : patch.triangles)
        for (const std::uint32_t v : t) visit(v);
      for (const auto& [t, o] : patch.fans)
        for (const std::uint32_t v : t) visit(v);
      auto canonical = [&](std::uint32_t v) {
        for (auto it = same.find(v); it != same.end(); it = same.find(v)) v = it->second;
        return v;
      };
      for (auto& t : patch.triangles)
        for (std::uint32_t& v : t) v = canonical(v);
      for (auto& [t, o] : patch.fans)
        for (std::uint32_t& v : t) v = canonical(v);
      std::erase_if(patch.fans, [](const auto& fo) {
        const auto& t = fo.first;
        return t[0] == t[1] || t[1] == t[2] || t[2] == t[0];
      });
    }
    std::erase_if(patch.triangles, [&](const Mesh::Triangle& t) {
      return t[0] == t[1] || t[1] == t[2] || t[2] == t[0] || at_pos(t[0]) == at_pos(t[1]) ||
             at_pos(t[1]) == at_pos(t[2]) || at_pos(t[2]) == at_pos(t[0]);
    });
    drop_unused(patch, nv);
  }

  // The patch's vertices renumbered without those no triangle uses any more (rim vertices
  // renamed to hole vertices, corners of dropped triangles).
  static void drop_unused(Patch& patch, std::uint32_t nv) {
    std::vector<std::uint32_t> renumber(patch.positions.size(), kNone);
    std::vector<std::uint32_t> order;  // old patch index, in first use
    auto visit = [&](std::uint32_t v) {
      if (v >= nv && renumber[v - nv] == kNone) {
        renumber[v - nv] = nv + static_cast<std::uint32_t>(order.size());
        order.push_back(v - nv);
      }
    };
    for (const auto& t : patch.triangles)
      for (const std::uint32_t v : t) visit(v);
    for (const auto& [t, o] : patch.fans)
      for (const std::uint32_t v : t) visit(v);
    std::vector<glm::dvec3> positions, closest;
    std::vector<std::uint32_t> origins;
    for (const std::uint32_t k : order) {
      positions.push_back(patch.positions[k]);
      closest.push_back(patch.vertex_closest[k]);
      origins.push_back(patch.vertex_origin[k]);
    }
    patch.positions = std::move(positions);
    patch.vertex_closest = std::move(closest);
    patch.vertex_origin = std::move(origins);
    for (auto& t : patch.triangles)
      for (std::uint32_t& v : t)
        if (v >= nv) v = renumber[v - nv];
    for (auto& [t, o] : patch.fans)
      for (std::uint32_t& v : t)
        if (v >= nv) v = renumber[v - nv];
  }


 private:
  const Mesh& mesh_;
  const VertexCorners& vc_;
  const Skeleton& skeleton_;
  const VolumePatchOptions& options_;
  std::vector<std::uint32_t> opposite_;
  std::vector<std::uint32_t> seen_;  // per triangle: the last nearest_in_bins query that met it
  std::uint32_t query_ = 0;
};


// The mesh with the patches in `use` in place of their cut triangles; `first_new[p]` receives
// the index of patch p's first triangle in the result (its triangles follow in order).
Mesh assemble(const Mesh& mesh, const std::vector<Patch>& patches, const std::vector<std::uint8_t>& use,
              std::vector<std::uint32_t>& origin, std::vector<std::uint32_t>& first_new) {
  const auto nv = static_cast<std::uint32_t>(mesh.positions.size());
  const std::size_t nf = mesh.triangles.size();
  std::vector<std::uint8_t> gone(nf, 0);
  for (std::size_t p = 0; p < patches.size(); ++p) {
    if (!use[p]) continue;
    for (const std::uint32_t f : patches[p].cut) gone[f] = 1;
    for (const std::uint32_t f : patches[p].replaced) gone[f] = 1;
  }
  Mesh out;
  out.positions = mesh.positions;
  const bool uvs = mesh.corner_uvs.size() == nf, branches = mesh.triangle_branch.size() == nf;
  const bool nodes = mesh.vertex_node.size() == nv, strands = mesh.vertex_strand.size() == nv;
  if (nodes) out.vertex_node = mesh.vertex_node;
  if (strands) out.vertex_strand = mesh.vertex_strand;
  origin.clear();
  for (std::uint32_t f = 0; f < nf; ++f) {
    if (gone[f]) continue;
    out.triangles.push_back(mesh.triangles[f]);
    origin.push_back(f);
    if (uvs) out.corner_uvs.push_back(mesh.corner_uvs[f]);
  }
  first_new.assign(patches.size(), kNone);
  // A new triangle: `u` in the result's numbering, `t` in the patch's, `o` its origin.
  auto add_triangle = [&](const Mesh::Triangle& u, const Mesh::Triangle& t, std::uint32_t o, const Patch& patch) {
    out.triangles.push_back(u);
    origin.push_back(o);
    if (uvs) {
      const auto& ot = mesh.triangles[o];
      const auto& ouv = mesh.corner_uvs[o];
      std::array<glm::vec2, 3> uv{};
      for (int k = 0; k < 3; ++k) {
        const glm::dvec3 q = t[k] >= nv ? patch.vertex_closest[t[k] - nv] : mesh.positions[t[k]];
        const glm::dvec3 w = barycentric(mesh.positions[ot[0]], mesh.positions[ot[1]], mesh.positions[ot[2]], q);
        uv[k] = glm::vec2(w.x * glm::dvec2(ouv[0]) + w.y * glm::dvec2(ouv[1]) + w.z * glm::dvec2(ouv[2]));
      }
      out.corner_uvs.push_back(uv);
    }
  };
  for (std::size_t p = 0; p < patches.size(); ++p) {
    if (!use[p]) continue;
    const Patch& patch = patches[p];
    const auto base = static_cast<std::uint32_t>(out.positions.size());
    out.positions.insert(out.positions.end(), patch.positions.begin(), patch.positions.end());
    for (std::size_t k = 0; k < patch.positions.size(); ++k) {
      const auto& t = mesh.triangles[patch.vertex_origin[k]];
      int best = 0;
      for (int c = 1; c < 3; ++c) {
        if (glm::distance(mesh.positions[t[c]], patch.vertex_closest[k]) <
            glm::distance(mesh.positions[t[best]], patch.vertex_closest[k]))
          best = c;
      }
      if (nodes) out.vertex_node.push_back(mesh.vertex_node[t[best]]);
      if (strands) out.vertex_strand.push_back(StrandId{});
    }
    first_new[p] = static_cast<std::uint32_t>(out.triangles.size());
    for (const Mesh::Triangle& t : patch.triangles) {
      Mesh::Triangle u = t;
      for (std::uint32_t& v : u)
        if (v >= nv) v = v - nv + base;
      // The origin: the nearest mesh triangle of its first patch vertex (or of the cut).
      std::uint32_t o = patch.vertex_origin.front();
      for (const std::uint32_t v : t)
        if (v >= nv) {
          o = patch.vertex_origin[v - nv];
          break;
        }
      add_triangle(u, t, o, patch);
    }
    for (const auto& [t, o] : patch.fans) {
      Mesh::Triangle u = t;
      for (std::uint32_t& v : u)
        if (v >= nv) v = v - nv + base;
      add_triangle(u, t, o, patch);
    }
  }
  if (branches) {
    out.triangle_branch.reserve(origin.size());
    for (const std::uint32_t o : origin) out.triangle_branch.push_back(mesh.triangle_branch[o]);
  }
  if (!mesh.normals.empty()) out.normals = angle_weighted_normals(out);
  return out;
}

}  // namespace

VolumePatchStats volume_patch(Mesh& mesh, const std::vector<std::array<std::uint32_t, 2>>& pairs,
                              const Skeleton& skeleton, const VolumePatchOptions& options,
                              std::vector<std::uint32_t>& origin) {
  const std::span<const double> node_radius = skeleton.radius;
  const std::span<const glm::dvec3> anchors = skeleton.position;
  VolumePatchStats st;
  origin.resize(mesh.triangles.size());
  std::iota(origin.begin(), origin.end(), 0u);
  if (pairs.empty() && options.uncovered.empty()) return st;
  const VertexCorners vc = vertex_corners(mesh);
  const bool nodes = mesh.vertex_node.size() == mesh.positions.size();

  // Clusters: the pairs' triangles joined by the pairs and by shared vertices.
  std::vector<std::uint32_t> tris;
  for (const auto& [f, g] : pairs) {
    tris.push_back(f);
    tris.push_back(g);
  }
  std::sort(tris.begin(), tris.end());
  tris.erase(std::unique(tris.begin(), tris.end()), tris.end());
  auto slot = [&](std::uint32_t f) {
    return static_cast<std::uint32_t>(std::lower_bound(tris.begin(), tris.end(), f) - tris.begin());
  };
  UnionFind dsu(tris.size());
  for (const auto& [f, g] : pairs) dsu.unite(slot(f), slot(g));
  {
    std::unordered_map<std::uint32_t, std::uint32_t> by_vertex;
    for (std::uint32_t s = 0; s < tris.size(); ++s) {
      for (const std::uint32_t v : mesh.triangles[tris[s]]) {
        const auto [it, fresh] = by_vertex.try_emplace(v, s);
        if (!fresh) dsu.unite(s, it->second);
      }
    }
  }
  // Each cluster's region: its box grown by `reach` local radii; overlapping regions merge.
  std::map<std::uint32_t, Patch> by_root;
  for (std::uint32_t s = 0; s < tris.size(); ++s) {
    Patch& p = by_root[dsu.find(s)];
    for (const std::uint32_t v : mesh.triangles[tris[s]]) {
      p.region.add(mesh.positions[v]);
      const double r = nodes && mesh.vertex_node[v].valid() ? node_radius[mesh.vertex_node[v].idx()] : 0.0;
      p.radius_max = std::max(p.radius_max, r);
      if (r > 0) p.radius_min = p.radius_min > 0 ? std::min(p.radius_min, r) : r;
    }
  }
  std::vector<Patch> patches;
  for (auto& [root, p] : by_root) {
    p.region = p.region.grown(options.reach * std::max(p.radius_min, 1e-4));
    patches.push_back(std::move(p));
  }
  // Regions around nodes left outside: the node's own scale (thinner twigs there are drawn at
  // min_twig_voxels), and a box that reaches the surface the slicing left nearby.
  for (const std::uint32_t n : options.uncovered) {
    Patch p;
    p.node = true;
    p.radius_max = std::max(node_radius[n], 1e-4);
    p.region.add(anchors[n]);
    p.region = p.region.grown((options.reach + 1) * p.radius_max);
    // The scale: the thinnest of the node's neighbours in the tree within the box (its parent,
    // and the nodes below it up to three edges down), down to a quarter of its radius (a twig
    // drawn thicker than it is costs fidelity where the patch has many vertices).
    p.radius_min = p.radius_max;
    auto take = [&](NodeId m) {
      if (m.valid() && p.region.contains(anchors[m.idx()]))
        p.radius_min = std::min(p.radius_min, std::max(node_radius[m.idx()], p.radius_max / 4));
    };
    take(skeleton.parent[n]);
    std::vector<NodeId> level{NodeId(n)};
    for (int depth = 0; depth < 3; ++depth) {
      std::vector<NodeId> below;
      for (const NodeId m : level) {
        for (const NodeId c : skeleton.children[m.idx()]) {
          if (!c.valid()) continue;
          take(c);
          below.push_back(c);
        }
      }
      level = std::move(below);
    }
    patches.push_back(std::move(p));
  }
  st.clusters = patches.size();
  // Overlapping regions merge: passes of a sweep along x joining every overlapping pair,
  // until none overlap (a merged box can reach a further one).
  for (bool merged = true; merged;) {
    merged = false;
    std::vector<std::uint32_t> order(patches.size());
    std::iota(order.begin(), order.end(), 0u);
    std::sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) {
      return std::tie(patches[a].region.lo.x, a) < std::tie(patches[b].region.lo.x, b);
    });
    UnionFind joined(patches.size());
    std::vector<std::uint32_t> open;
    for (const std::uint32_t i : order) {
      std::erase_if(open, [&](std::uint32_t a) { return patches[a].region.hi.x < patches[i].region.lo.x; });
      for (const std::uint32_t a : open) {
        if (!patches[a].region.overlaps(patches[i].region)) continue;
        joined.unite(a, i);
        merged = true;
      }
      open.push_back(i);
    }
    if (!merged) break;
    std::vector<Patch> next;
    std::map<std::uint32_t, std::size_t> merged_into;
    for (std::uint32_t i = 0; i < patches.size(); ++i) {
      const auto [it, fresh] = merged_into.try_emplace(joined.find(i), next.size());
      if (fresh) {
        next.push_back(std::move(patches[i]));
        continue;
      }
      Patch& into = next[it->second];
      into.region.add(patches[i].region);
      into.radius_max = std::max(into.radius_max, patches[i].radius_max);
      into.radius_min = std::min(into.radius_min, patches[i].radius_min);
      into.node = into.node || patches[i].node;
    }
    patches = std::move(next);
  }
  // With uncovered nodes, only their regions (and those of the pairs merged into them): the
  // pairs' own were tried before (repair.cpp's first pass).
  if (!options.uncovered.empty()) std::erase_if(patches, [](const Patch& p) { return !p.node; });
  // Smallest regions first, within a budget of voxels for the whole step: its cost is
  // bounded however many regions a tree has.
  std::stable_sort(patches.begin(), patches.end(), [](const Patch& a, const Patch& b) {
    const dvec3 sa = a.region.hi - a.region.lo, sb = b.region.hi - b.region.lo;
    return sa.x * sa.y * sa.z < sb.x * sb.y * sb.z;
  });

  const TriangleBins bins(mesh);
  Builder builder(mesh, vc, skeleton, options);
  builder.link();
  std::vector<std::uint8_t> use(patches.size(), 0);
  std::vector<std::uint8_t> absorbed(patches.size(), 0);  // merged into a region that grew into it
  auto left_out = [&](std::size_t q) { return q < options.leave_out.size() && options.leave_out[q]; };
  for (std::size_t p = 0; p < patches.size(); ++p) {
    if (absorbed[p]) continue;
    if (left_out(p)) {
      ++st.failures["not tried again after the step was refused (not made, or more pairs in it)"];
      continue;
    }
    // Where the box's faces cut the surface where it is not yet clean (branches still
    // overlapping there), the box grows, up to four times, as long as it stays clear of the
    // patches made; regions not made that it grows into are merged into it (two regions a
    // voxel apart each failing at the other's rims).
    for (int attempt = 0;; ++attempt) {
      if (st.voxels >= options.max_total_voxels) {
        patches[p].failure = "the step's budget of voxels is spent";
        break;
      }
      builder.build(patches[p], bins);
      st.voxels += patches[p].voxels;
      if (patches[p].failure.empty() || attempt == 4 || patches[p].voxels == 0) break;
      const Box grown = patches[p].region.grown(options.reach * std::max(patches[p].radius_min, 1e-4));
      bool clear = true;
      std::vector<std::size_t> into;
      for (std::size_t q = 0; q < patches.size() && clear; ++q) {
        if (q == p || absorbed[q] || !grown.overlaps(patches[q].region)) continue;
        clear = !use[q] && !left_out(q);
        into.push_back(q);
      }
      if (!clear) break;
      Patch fresh;
      fresh.region = grown;
      fresh.radius_min = patches[p].radius_min;
      fresh.radius_max = patches[p].radius_max;
      fresh.node = patches[p].node;
      for (const std::size_t q : into) {
        fresh.region.add(patches[q].region);
        fresh.radius_min = std::min(fresh.radius_min, patches[q].radius_min);
        fresh.radius_max = std::max(fresh.radius_max, patches[q].radius_max);
        fresh.node = fresh.node || patches[q].node;
        absorbed[q] = 1;
        if (q < p && --st.failures[patches[q].failure] == 0) st.failures.erase(patches[q].failure);
      }
      patches[p] = std::move(fresh);
    }
    use[p] = patches[p].failure.empty();
    if (!use[p]) ++st.failures[patches[p].failure];
  }

  // Keep the patches that make no crossing, close up, and keep every anchor inside that was.
  std::vector<std::uint8_t> was_inside = inside_closed_mesh(mesh, anchors);
  Mesh out;
  std::vector<std::uint32_t> first_new;
  for (int round = 0; round < 3; ++round) {
    if (std::none_of(use.begin(), use.end(), [](std::uint8_t u) { return u != 0; })) break;
    out = assemble(mesh, patches, use, origin, first_new);
    std::vector<std::uint32_t> fresh;
    std::vector<std::uint32_t> patch_of(out.triangles.size(), kNone);
    for (std::size_t p = 0; p < patches.size(); ++p) {
      if (!use[p]) continue;
      for (std::uint32_t f = first_new[p]; f < first_new[p] + patches[p].triangles.size() + patches[p].fans.size(); ++f) {
        fresh.push_back(f);
        patch_of[f] = static_cast<std::uint32_t>(p);
      }
    }
    bool changed = false;
    auto reject = [&](std::uint32_t p, const char* why) {
      if (p == kNone || !use[p]) return;
      use[p] = 0;
      changed = true;
      ++st.failures[why];
    };
    // Every half-edge of a patch triangle has exactly one twin.
    const VertexCorners ovc = vertex_corners(out);
    for (const std::uint32_t f : fresh) {
      const auto& t = out.triangles[f];
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = t[k], b = t[(k + 1) % 3];
        int twins = 0, same = 0;
        for (std::uint32_t c = ovc.begin[a]; c < ovc.begin[a + 1]; ++c) {
          const auto& u = out.triangles[ovc.corner[c] / 3];
          const std::uint32_t kk = ovc.corner[c] % 3;
          same += u[(kk + 1) % 3] == b;
          twins += u[(kk + 2) % 3] == b;
        }
        if (twins != 1 || same != 1) {
          reject(patch_of[f], "the patch does not close up");
        }
      }
    }
    // A patch whose triangles fall into two parts of the result cut a branch off (the volume's
    // surface did not join a twig's rim to the rest).
    {
      UnionFind joined(out.positions.size());
      for (const auto& t : out.triangles) {
        joined.unite(t[0], t[1]);
        joined.unite(t[1], t[2]);
      }
      std::vector<std::uint32_t> part_of(patches.size(), kNone);
      for (const std::uint32_t f : fresh) {
        const std::uint32_t part = joined.find(out.triangles[f][0]);
        std::uint32_t& seen = part_of[patch_of[f]];
        if (seen == kNone) seen = part;
        else if (seen != part) reject(patch_of[f], "the patch cuts a branch off");
      }
    }
    std::vector<std::size_t> made(patches.size(), 0);
    std::vector<std::array<std::uint32_t, 2>> fresh_pairs = TriangleIntersections(out).pairs_touching(fresh);
    for (const auto& [f, g] : fresh_pairs) {
      for (const std::uint32_t t : {f, g})
        if (patch_of[t] != kNone) ++made[patch_of[t]];
      if (options.allow_crossings) continue;
      reject(patch_of[f], "the patch would make a crossing");
      reject(patch_of[g], "the patch would make a crossing");
    }
    if (!changed) {
      const std::vector<std::uint8_t> inside = inside_closed_mesh(out, anchors);
      for (std::size_t a = 0; a < anchors.size(); ++a) {
        if (!was_inside[a] || inside[a]) continue;
        // The patch whose region holds the anchor lost it.
        for (std::size_t p = 0; p < patches.size(); ++p)
          if (use[p] && patches[p].region.grown(patches[p].radius_max).contains(anchors[a]))
            reject(static_cast<std::uint32_t>(p), "the patch leaves a skeleton node outside");
      }
    }
    if (!changed) {
      st.seam_crossings.assign(patches.size(), 0);
      st.regions.resize(patches.size());
      st.made.assign(use.begin(), use.end());
      for (std::size_t p = 0; p < patches.size(); ++p) {
        st.regions[p] = {patches[p].region.lo, patches[p].region.hi};
        if (!use[p]) continue;
        st.seam_crossings[p] = made[p];
        ++st.patched;
        st.removed_triangles += patches[p].cut.size();
        st.new_triangles += patches[p].triangles.size() + patches[p].fans.size();
      }
      std::sort(fresh.begin(), fresh.end());
      st.new_triangles_of_result = std::move(fresh);
      st.pairs_of_new = std::move(fresh_pairs);
      mesh = std::move(out);
      return st;
    }
  }
  origin.resize(mesh.triangles.size());
  std::iota(origin.begin(), origin.end(), 0u);
  return st;
}

}  // namespace sm
