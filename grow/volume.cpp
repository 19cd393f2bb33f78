// Crown volumes (Clasping Trees §5). The paper voxelizes every input mesh and combines the layers
// with logical or / and-not; we keep the primitives analytic (exact, no resolution to choose)
// and voxelize only arbitrary meshes, then combine by the same union-minus-obstacles rule.
// Points are scattered uniformly by rejection in the bounds, which is what "pick a random
// voxel, then a random position inside it" amounts to for equally sized voxels.

#include "grow/volume.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/errors.h"
#include "core/rng.h"

namespace sm {
namespace {

constexpr std::size_t kNoGrid = std::numeric_limits<std::size_t>::max();
constexpr std::uint64_t kScatterStream = 0x5CA77E5ull;  // stream kind for attraction points
constexpr std::uint64_t kVolumeStream = 0x701u;         // stream kind for volume estimates
constexpr std::size_t kMaxVoxels = 64u << 20;
constexpr int kMaxTries = 100'000;

const char* kind_name(ShapeKind k) {
  switch (k) {
    case ShapeKind::sphere:
      return "sphere";
    case ShapeKind::ellipsoid:
      return "ellipsoid";
    case ShapeKind::box:
      return "box";
    case ShapeKind::cylinder:
      return "cylinder";
    case ShapeKind::cone:
      return "cone";
    case ShapeKind::mesh:
      return "mesh";
  }
  return "?";
}

bool finite(const dvec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

void check_shape(const VolumeShape& s, const std::string& where) {
  auto fail = [&](const std::string& rule) {
    throw InvalidInputError(where + " (" + kind_name(s.kind) + "): " + rule);
  };
  if (!finite(s.center)) fail("center is not finite");
  switch (s.kind) {
    case ShapeKind::sphere:
      if (!(s.radius > 0) || !std::isfinite(s.radius)) fail("radius must be > 0");
      break;
    case ShapeKind::ellipsoid:
    case ShapeKind::box:
      if (!(s.radii.x > 0 && s.radii.y > 0 && s.radii.z > 0) || !finite(s.radii)) fail("radii must all be > 0");
      break;
    case ShapeKind::cylinder:
    case ShapeKind::cone:
      if (!(s.radius > 0) || !std::isfinite(s.radius)) fail("radius must be > 0");
      if (!(s.height > 0) || !std::isfinite(s.height)) fail("height must be > 0");
      if (s.kind == ShapeKind::cone && (!(s.top_radius >= 0) || !std::isfinite(s.top_radius))) {
        fail("top_radius must be >= 0");
      }
      break;
    case ShapeKind::mesh:
      if (s.mesh_triangles.empty()) fail("the mesh has no triangles");
      for (const auto& v : s.mesh_vertices) {
        if (!finite(v)) fail("a mesh vertex is not finite");
      }
      for (std::size_t t = 0; t < s.mesh_triangles.size(); ++t) {
        for (auto i : s.mesh_triangles[t]) {
          if (i >= s.mesh_vertices.size()) {
            fail("triangle " + std::to_string(t) + " refers to vertex " + std::to_string(i) + " but there are only " +
                 std::to_string(s.mesh_vertices.size()));
          }
        }
      }
      break;
  }
}

void shape_bounds(const VolumeShape& s, dvec3& lo, dvec3& hi) {
  switch (s.kind) {
    case ShapeKind::sphere:
      lo = s.center - dvec3(s.radius);
      hi = s.center + dvec3(s.radius);
      return;
    case ShapeKind::ellipsoid:
    case ShapeKind::box:
      lo = s.center - s.radii;
      hi = s.center + s.radii;
      return;
    case ShapeKind::cylinder:
    case ShapeKind::cone: {
      const double r = s.kind == ShapeKind::cone ? std::max(s.radius, s.top_radius) : s.radius;
      lo = s.center - dvec3(r, r, 0);
      hi = s.center + dvec3(r, r, s.height);
      return;
    }
    case ShapeKind::mesh:
      lo = dvec3(std::numeric_limits<double>::infinity());
      hi = -lo;
      for (const auto& v : s.mesh_vertices) {
        lo = glm::min(lo, v);
        hi = glm::max(hi, v);
      }
      return;
  }
}

/// Voxelizes a closed mesh by ray parity along +z through every voxel column centre: the
/// crossings of the column with the triangles, sorted, bound the inside intervals. Column
/// centres are nudged by a tiny irrational fraction of a cell so they never hit a shared edge
/// or vertex exactly (which would count a crossing twice).
template <class Grid>
Grid voxelize(const VolumeShape& s, double cell, const std::string& where) {
  Grid g;
  dvec3 lo, hi;
  shape_bounds(s, lo, hi);
  g.cell = cell;
  g.origin = lo - dvec3(cell);
  std::size_t total = 1;
  for (int a = 0; a < 3; ++a) {
    const double cells = std::ceil((hi[a] - lo[a]) / cell) + 2;
    if (!(cells < 1e6)) throw InvalidInputError(where + " (mesh): too many voxels; raise voxel_size");
    g.dims[static_cast<std::size_t>(a)] = static_cast<int>(cells);
    total *= static_cast<std::size_t>(cells);
  }
  if (total > kMaxVoxels) {
    throw InvalidInputError(where + " (mesh): " + std::to_string(total) + " voxels exceed the limit of " +
                            std::to_string(kMaxVoxels) + "; raise voxel_size");
  }
  const int nx = g.dims[0], ny = g.dims[1], nz = g.dims[2];
  g.inside.assign(total, 0);
  std::vector<std::vector<double>> hits(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
  const double jx = 1.234567e-7 * cell, jy = 2.718281e-7 * cell;
  for (const auto& tri : s.mesh_triangles) {
    const dvec3 a = s.mesh_vertices[tri[0]], b = s.mesh_vertices[tri[1]], c = s.mesh_vertices[tri[2]];
    const double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (area == 0) continue;  // vertical triangle: no column crosses it transversally
    const double tx0 = std::min({a.x, b.x, c.x}), tx1 = std::max({a.x, b.x, c.x});
    const double ty0 = std::min({a.y, b.y, c.y}), ty1 = std::max({a.y, b.y, c.y});
    const int i0 = std::max(0, static_cast<int>(std::floor((tx0 - g.origin.x) / cell - 0.5)));
    const int i1 = std::min(nx - 1, static_cast<int>(std::ceil((tx1 - g.origin.x) / cell - 0.5)));
    const int k0 = std::max(0, static_cast<int>(std::floor((ty0 - g.origin.y) / cell - 0.5)));
    const int k1 = std::min(ny - 1, static_cast<int>(std::ceil((ty1 - g.origin.y) / cell - 0.5)));
    for (int k = k0; k <= k1; ++k) {
      for (int i = i0; i <= i1; ++i) {
        const double x = g.origin.x + (i + 0.5) * cell + jx, y = g.origin.y + (k + 0.5) * cell + jy;
        // Barycentric coordinates in the xy projection.
        const double wa = ((b.x - x) * (c.y - y) - (b.y - y) * (c.x - x)) / area;
        const double wb = ((c.x - x) * (a.y - y) - (c.y - y) * (a.x - x)) / area;
        const double wc = 1.0 - wa - wb;
        if (wa < 0 || wb < 0 || wc < 0) continue;
        hits[static_cast<std::size_t>(k) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(i)].push_back(
            wa * a.z + wb * b.z + wc * c.z);
      }
    }
  }
  for (int k = 0; k < ny; ++k) {
    for (int i = 0; i < nx; ++i) {
      auto& h = hits[static_cast<std::size_t>(k) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(i)];
      std::sort(h.begin(), h.end());
      for (std::size_t m = 0; m + 1 < h.size(); m += 2) {
        const int z0 = std::max(0, static_cast<int>(std::ceil((h[m] - g.origin.z) / cell - 0.5)));
        const int z1 = std::min(nz - 1, static_cast<int>(std::floor((h[m + 1] - g.origin.z) / cell - 0.5)));
        for (int z = z0; z <= z1; ++z) {
          g.inside[(static_cast<std::size_t>(z) * static_cast<std::size_t>(ny) + static_cast<std::size_t>(k)) *
                       static_cast<std::size_t>(nx) +
                   static_cast<std::size_t>(i)] = 1;
        }
      }
    }
  }
  return g;
}

/// A uniform point of the unit cube. The draws are sequenced z, y, x: the order GCC gave the
/// former `dvec3(rng.uniform(), rng.uniform(), rng.uniform())`, whose argument order C++ leaves
/// unspecified (clang drew x first and grew other trees from the same seed).
dvec3 unit_cube_point(Rng& rng) {
  const double z = rng.uniform();
  const double y = rng.uniform();
  const double x = rng.uniform();
  return {x, y, z};
}

}  // namespace

bool shape_contains(const VolumeShape& s, const dvec3& p) {
  const dvec3 d = p - s.center;
  switch (s.kind) {
    case ShapeKind::sphere:
      return glm::dot(d, d) <= s.radius * s.radius;
    case ShapeKind::ellipsoid: {
      const dvec3 q = d / s.radii;
      return glm::dot(q, q) <= 1.0;
    }
    case ShapeKind::box:
      return std::abs(d.x) <= s.radii.x && std::abs(d.y) <= s.radii.y && std::abs(d.z) <= s.radii.z;
    case ShapeKind::cylinder:
      return d.z >= 0 && d.z <= s.height && d.x * d.x + d.y * d.y <= s.radius * s.radius;
    case ShapeKind::cone: {
      if (d.z < 0 || d.z > s.height) return false;
      const double r = s.radius + (s.top_radius - s.radius) * (d.z / s.height);
      return d.x * d.x + d.y * d.y <= r * r;
    }
    case ShapeKind::mesh:
      throw InvalidInputError("shape_contains: mesh shapes must be voxelized; use Volume");
  }
  return false;
}

Volume::Volume(const CrownVolume& crown) : crown_(crown) {
  if (crown_.shapes.empty()) throw InvalidInputError("crown: no shapes; a crown volume needs at least one shape");
  if (!(crown_.voxel_size > 0) || !std::isfinite(crown_.voxel_size)) {
    throw InvalidInputError("crown: voxel_size must be > 0");
  }
  if (!(crown_.shell_thickness >= 0) || !std::isfinite(crown_.shell_thickness)) {
    throw InvalidInputError("crown: shell_thickness must be >= 0");
  }
  auto prepare = [&](const std::vector<VolumeShape>& list, const char* name, std::vector<std::size_t>& slot) {
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string where = std::string("crown: ") + name + "[" + std::to_string(i) + "]";
      check_shape(list[i], where);
      if (list[i].kind == ShapeKind::mesh) {
        slot.push_back(grids_.size());
        grids_.push_back(voxelize<Grid>(list[i], crown_.voxel_size, where));
      } else {
        slot.push_back(kNoGrid);
      }
    }
  };
  prepare(crown_.shapes, "shapes", grid_of_shape_);
  prepare(crown_.obstacles, "obstacles", grid_of_obstacle_);
  lower_ = dvec3(std::numeric_limits<double>::infinity());
  upper_ = -lower_;
  for (const auto& s : crown_.shapes) {
    dvec3 lo, hi;
    shape_bounds(s, lo, hi);
    lower_ = glm::min(lower_, lo);
    upper_ = glm::max(upper_, hi);
  }
}

bool Volume::in_shape(std::size_t grid_slot, const VolumeShape& s, const dvec3& p) const {
  if (grid_slot == kNoGrid) return shape_contains(s, p);
  const Grid& g = grids_[grid_slot];
  const dvec3 q = (p - g.origin) / g.cell;
  const int i = static_cast<int>(std::floor(q.x)), k = static_cast<int>(std::floor(q.y)),
            z = static_cast<int>(std::floor(q.z));
  if (i < 0 || k < 0 || z < 0 || i >= g.dims[0] || k >= g.dims[1] || z >= g.dims[2]) return false;
  return g.inside[(static_cast<std::size_t>(z) * static_cast<std::size_t>(g.dims[1]) + static_cast<std::size_t>(k)) *
                      static_cast<std::size_t>(g.dims[0]) +
                  static_cast<std::size_t>(i)] != 0;
}

bool Volume::solid_contains(const dvec3& p) const {
  bool in = false;
  for (std::size_t i = 0; i < crown_.shapes.size() && !in; ++i) in = in_shape(grid_of_shape_[i], crown_.shapes[i], p);
  if (!in) return false;
  for (std::size_t i = 0; i < crown_.obstacles.size(); ++i) {
    if (in_shape(grid_of_obstacle_[i], crown_.obstacles[i], p)) return false;
  }
  return true;
}

bool Volume::contains(const dvec3& p) const {
  if (!solid_contains(p)) return false;
  const double t = crown_.shell_thickness;
  if (t <= 0) return true;
  // In the shell when some point at distance t along a coordinate axis is outside.
  for (int a = 0; a < 3; ++a) {
    for (double sign : {-1.0, 1.0}) {
      dvec3 q = p;
      q[a] += sign * t;
      if (!solid_contains(q)) return true;
    }
  }
  return false;
}

std::vector<dvec3> scatter_points(const Volume& volume, std::size_t count, std::uint64_t seed) {
  std::vector<dvec3> points(count);
  std::vector<std::uint8_t> failed(count, 0);
  const dvec3 lo = volume.lower(), size = volume.upper() - volume.lower();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, 256), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      Rng rng(derive_seed(seed, kScatterStream, i));
      failed[i] = 1;
      for (int t = 0; t < kMaxTries; ++t) {
        const dvec3 p = lo + unit_cube_point(rng) * size;
        if (volume.contains(p)) {
          points[i] = p;
          failed[i] = 0;
          break;
        }
      }
    }
  });
  if (std::find(failed.begin(), failed.end(), std::uint8_t{1}) != failed.end()) {
    throw InvalidInputError("crown: no point inside the volume found in " + std::to_string(kMaxTries) +
                            " tries; the shapes are empty, too thin, or covered by the obstacles");
  }
  return points;
}

double estimate_volume(const Volume& volume, std::size_t samples, std::uint64_t seed) {
  if (samples == 0) return 0;
  Rng rng(derive_seed(seed, kVolumeStream));
  const dvec3 lo = volume.lower(), size = volume.upper() - volume.lower();
  std::size_t in = 0;
  for (std::size_t i = 0; i < samples; ++i) {
    in += volume.contains(lo + unit_cube_point(rng) * size) ? 1 : 0;
  }
  return size.x * size.y * size.z * double(in) / double(samples);
}

}  // namespace sm
