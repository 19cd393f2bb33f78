#pragma once
/// Triangle quality: how a mesh looks close up, as an artist would judge a hero asset. The
/// figures of `strandmesh check` under "triangle quality"; informative unless the caller asks
/// for limits (QualityLimits).
///
/// Definitions (angles in degrees):
///  - smallest angle of a triangle: the least of its three corner angles (0 for a degenerate
///    triangle); the shares count triangles with it under 1, 5 and 10 degrees.
///  - aspect ratio: longest edge over shortest altitude, scaled so that an equilateral
///    triangle has 1 (e_max² √3 / (4 area)); a right isosceles triangle has √3. Degenerate
///    triangles are left out of its percentiles.
///  - dihedral angle of an edge with two triangles: the angle between their normals (0 on a
///    flat surface, 90 on a cube's edge). Edges with one or more than two triangles, or a
///    triangle of zero area, are left out.
///  - caps (with a skeleton): a vertex at or beyond a tip node (its distance along the tip
///    edge, from the tip, at least -0.05 tip radii) whose nearest skeleton edge ends at that
///    tip; at or below the root the same for the root's edges. A triangle is a cap triangle
///    when its three vertices are cap vertices of one end; an edge is a cap edge when one of its
///    triangles is. Without a skeleton nothing counts as a cap.
///  - junctions (with a skeleton): edges whose midpoint lies within `junction_radii` times the
///    fork's radius of a node with two or more children.
///  - backward normal: a normal more than 90 degrees from the normal of a triangle it shades:
///    the vertex's normal at each of its triangles or, where the mesh has corner normals
///    (smoothing groups; a file whose copies of a vertex have different normals), each
///    corner's at its own triangle (normals_per_corner), so that the count is what a renderer
///    shows. Counted per vertex: the vertices with at least one such corner. A mesh without
///    normals is measured with its angle-weighted normals (normals_computed).
///
/// Cost: one pass over the triangles, a sort of the edges, and with a skeleton a nearest-edge
/// query per vertex.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/mesh.h"
#include "skeleton/skeleton.h"

namespace sm {

/// Goals a mesh may be held to (MeshCheckParams::quality_limits); the defaults are those of a
/// close-up: hero trees seen from a metre away.
struct QualityLimits {
  double max_share_under_10 = 0.02;       ///< largest share of triangles with an angle under 10 degrees (fraction)
  std::size_t max_under_1 = 0;            ///< most triangles with an angle under 1 degree (count)
  double max_junction_dihedral_p99 = 40;  ///< largest 99th percentile of the dihedral angle at junctions (degrees)
  std::size_t max_backward_normals = 0;   ///< most vertices with a backward normal (count)
};

struct QualityParams {
  double junction_radii = 3.0;  ///< junction edges: midpoint within this many fork radii of a fork (relative)
  std::size_t max_examples = 5;  ///< sharpest edges and backward vertices listed (count)
};

struct TriangleQuality {
  std::size_t triangles = 0;  ///< #F
  std::size_t under_1 = 0;    ///< triangles with their smallest angle under 1 degree
  std::size_t under_5 = 0;    ///< ... under 5 degrees
  std::size_t under_10 = 0;   ///< ... under 10 degrees
  double min_angle = 0;       ///< smallest angle of any triangle (degrees)
  double aspect_p95 = 0;      ///< 95th percentile of the aspect ratio (1 = equilateral)
  double aspect_max = 0;      ///< largest aspect ratio

  bool caps_known = false;          ///< a skeleton told where the caps are
  std::size_t edges = 0;            ///< edges measured for the dihedral angle (caps left out)
  std::size_t cap_edges = 0;        ///< edges left out as part of a cap
  double dihedral_p99 = 0;          ///< 99th percentile of the dihedral angle away from caps (degrees)
  double dihedral_max = 0;          ///< largest dihedral angle away from caps (degrees)
  std::size_t junction_edges = 0;   ///< of the edges measured, those at junctions (with a skeleton)
  double junction_dihedral_p99 = 0; ///< 99th percentile of the dihedral angle there (degrees)
  double junction_dihedral_max = 0; ///< largest dihedral angle there (degrees)
  std::vector<std::array<std::uint32_t, 2>> sharpest_edges;  ///< vertex pairs of the largest dihedral angles, largest first

  bool normals_computed = false;      ///< the mesh had no normals: its angle-weighted ones were measured
  bool normals_per_corner = false;    ///< the mesh had corner normals: each corner's was measured
  std::size_t backward_normals = 0;   ///< vertices with a normal more than 90 degrees from a triangle it shades
  std::vector<std::uint32_t> backward_normal_examples;  ///< vertex indices

  [[nodiscard]] double share_under_1() const { return triangles ? double(under_1) / double(triangles) : 0.0; }
  [[nodiscard]] double share_under_5() const { return triangles ? double(under_5) / double(triangles) : 0.0; }
  [[nodiscard]] double share_under_10() const { return triangles ? double(under_10) / double(triangles) : 0.0; }
  /// One sentence per limit not met ("3.1 % of the triangles have an angle under 10 degrees
  /// (limit 2 %)"); the junction limit only applies where junctions were measured.
  [[nodiscard]] std::vector<std::string> failures(const QualityLimits& limits) const;
};

/// Measures `mesh` (any mesh; topology need not be clean). `skeleton` (optional, the mesh's
/// frame) tells where the caps and junctions are. Throws InvalidInputError when a triangle
/// references a vertex that does not exist.
TriangleQuality measure_quality(const Mesh& mesh, const Skeleton* skeleton = nullptr, const QualityParams& params = {});

}  // namespace sm
