#pragma once
/// Crown volumes for the growers: where attraction points are scattered (Clasping Trees §5).
///
/// A crown volume is the union of simple shapes (sphere, ellipsoid, box, cylinder, cone or
/// frustum, or any closed triangle mesh, voxelized) minus the union of obstacle shapes. All
/// coordinates are in metres, z up, in the frame of the grown tree (root at the origin).
///
/// Use `Volume` (prepared once: mesh shapes are voxelized) for inside tests and
/// `scatter_points()` for uniformly distributed, seeded attraction points.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"

namespace sm {

/// The kind of one crown or obstacle shape.
enum class ShapeKind {
  sphere,     ///< `center`, `radius`
  ellipsoid,  ///< `center`, semi-axes `radii`
  box,        ///< `center`, half extents `radii`
  cylinder,   ///< bottom disc centre `center`, `radius`, `height` (along +z)
  cone,       ///< bottom disc centre `center`, bottom `radius`, `top_radius` (0: pointed), `height`
  mesh,       ///< closed triangle mesh `mesh_vertices` / `mesh_triangles`, voxelized
};

/// One shape of a crown volume. Only the fields its kind names are used.
struct VolumeShape {
  ShapeKind kind = ShapeKind::ellipsoid;  ///< which shape; default ellipsoid
  dvec3 center{0, 0, 6};                  ///< centre, or bottom disc centre for cylinder/cone (metres); default (0,0,6)
  double radius = 3.0;                    ///< sphere radius, cylinder radius, cone bottom radius (metres); default 3
  dvec3 radii{3, 3, 3};                   ///< ellipsoid semi-axes or box half extents (metres); default (3,3,3)
  double height = 4.0;                    ///< cylinder/cone height along +z (metres); default 4
  double top_radius = 0.0;                ///< cone radius at the top (metres, 0 = pointed); default 0
  std::vector<dvec3> mesh_vertices{};     ///< #V mesh vertices (metres), kind mesh only
  std::vector<std::array<std::uint32_t, 3>> mesh_triangles{};  ///< #F vertex indices of a closed mesh, kind mesh only
};

/// The region in which a grower scatters its attraction points.
struct CrownVolume {
  std::vector<VolumeShape> shapes{VolumeShape{}};  ///< union of these (default: one ellipsoid)
  std::vector<VolumeShape> obstacles{};            ///< subtracted from the union (default: none)
  double voxel_size = 0.05;                        ///< voxel edge for mesh shapes (metres); default 0.05
  double shell_thickness = 0.0;                    ///< > 0: only points within this distance of the boundary (metres,
                                 ///< approximately, for roots on surfaces, Clasping Trees §5); default 0 = solid
};

/// Analytic inside test of one shape (boundary counts as inside). Mesh shapes are not
/// analytic: for them this throws InvalidInputError; use Volume.
bool shape_contains(const VolumeShape& shape, const dvec3& p);

/// A prepared crown volume: mesh shapes voxelized once, then fast inside tests.
/// Holds state that is reused for many queries, hence a class.
class Volume {
 public:
  /// Checks and prepares the volume. Throws InvalidInputError naming the shape and the rule
  /// (no shapes, non-positive sizes, a mesh with bad indices or too many voxels).
  explicit Volume(const CrownVolume& crown);

  /// True when p is inside some shape and inside no obstacle (and within the shell, if any).
  [[nodiscard]] bool contains(const dvec3& p) const;
  /// Axis-aligned bounds of the union of the shapes (metres).
  [[nodiscard]] dvec3 lower() const { return lower_; }
  [[nodiscard]] dvec3 upper() const { return upper_; }
  [[nodiscard]] const CrownVolume& crown() const { return crown_; }

 private:
  struct Grid {
    dvec3 origin{0};
    double cell = 1;
    std::array<int, 3> dims{0, 0, 0};
    std::vector<std::uint8_t> inside;  // dims[0] * dims[1] * dims[2], x fastest
  };
  [[nodiscard]] bool in_shape(std::size_t grid_slot, const VolumeShape& s, const dvec3& p) const;
  [[nodiscard]] bool solid_contains(const dvec3& p) const;

  CrownVolume crown_;
  std::vector<Grid> grids_;                                    // one per mesh shape, shapes first then obstacles
  std::vector<std::size_t> grid_of_shape_, grid_of_obstacle_;  // index into grids_ or SIZE_MAX
  dvec3 lower_{0}, upper_{0};
};

/// `count` points uniformly distributed in the volume (rejection sampling in its bounds).
/// Point i is drawn from its own stream `derive_seed(seed, kind, i)`, so changing the count
/// keeps the points that remain (core/rng.h); runs in parallel with identical output for
/// any thread count. Throws InvalidInputError when the volume is empty (no point found in
/// 100,000 tries).
std::vector<dvec3> scatter_points(const Volume& volume, std::size_t count, std::uint64_t seed);

/// The volume of the region in cubic metres, estimated by a seeded Monte Carlo count with
/// `samples` samples in the bounds (for attraction point densities, Clasping Trees eq. 11).
double estimate_volume(const Volume& volume, std::size_t samples = 200'000, std::uint64_t seed = 1);

}  // namespace sm
