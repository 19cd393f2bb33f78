#pragma once
/// The triangle mesh produced by the meshing stage and consumed by export and checks.

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include <glm/glm.hpp>

#include "core/ids.h"

namespace sm {

/// A welded, indexed triangle mesh (structure of arrays).
///
/// Triangles are counter-clockwise seen from outside. Vertices are shared between all
/// triangles that meet there (the mesh is welded, so topology checks work on it directly);
/// attributes that are discontinuous (UV seams, normals at creases) are stored per corner and
/// only split into separate vertices by the exporters.
struct Mesh {
  using Triangle = std::array<std::uint32_t, 3>;

  std::vector<glm::dvec3> positions;  ///< #V, world coordinates of the input (metres)
  std::vector<Triangle> triangles;    ///< #F vertex indices, CCW seen from outside

  std::vector<glm::dvec3> normals;                   ///< #V unit normals, or empty
  std::vector<std::array<glm::vec2, 3>> corner_uvs;  ///< #F × 3 texture coordinates, or empty
  /// #F × 3 unit normals where a vertex's fan is split at creases (split_vertex_normals), or
  /// empty: then every corner takes its vertex's `normals` entry.
  std::vector<std::array<glm::vec3, 3>> corner_normals;
  std::vector<StrandId> vertex_strand;               ///< #V strand the vertex lies on (invalid: cap centre), or empty
  std::vector<NodeId> vertex_node;             ///< #V skeleton node whose edge or section made the vertex, or empty
  std::vector<std::uint32_t> triangle_branch;  ///< #F branch id (see Skeleton::branch_id), or empty

  [[nodiscard]] std::size_t vertex_count() const { return positions.size(); }
  [[nodiscard]] std::size_t triangle_count() const { return triangles.size(); }
  [[nodiscard]] bool empty() const { return triangles.empty(); }
  /// The normal of triangle t, not normalised: its length is twice the area, and it points
  /// outwards for a triangle counter-clockwise seen from outside.
  [[nodiscard]] glm::dvec3 face_normal(const Triangle& t) const {
    const glm::dvec3& p = positions[t[0]];
    return glm::cross(positions[t[1]] - p, positions[t[2]] - p);
  }
};

/// The corners (3 f + k: corner k of triangle f) around every vertex, in triangle order:
/// those of vertex v are corner[begin[v]] .. corner[begin[v + 1] - 1] (#V + 1 offsets).
struct VertexCorners {
  std::vector<std::uint32_t> begin;
  std::vector<std::uint32_t> corner;
};
/// Precondition: every triangle index is a vertex of the mesh.
VertexCorners vertex_corners(const Mesh& mesh);

/// The half-edges a->b that do not have exactly one twin b->a, or that occur more than once
/// (a welded, closed, consistently oriented 2-manifold has none). Each vertex is checked on its
/// own corners: the edges leaving it (to the next corner of each of its triangles) against
/// those arriving (from the previous one). `corners` is the mesh's vertex_corners.
std::size_t unpaired_half_edges(const Mesh& mesh, const VertexCorners& corners);

/// Angle-weighted vertex normals of the welded mesh (unit length; a vertex
/// with no non-degenerate incident triangle gets (0,0,1)).
std::vector<glm::dvec3> angle_weighted_normals(const Mesh& mesh);
/// The same, with the mesh's vertex_corners already at hand.
std::vector<glm::dvec3> angle_weighted_normals(const Mesh& mesh, const VertexCorners& corners);

/// Per-corner normals with smoothing groups ("auto smooth"), so that no corner's normal faces
/// away from its triangle (a renderer shades such a triangle black). Each vertex's fan is cut
/// at its crease edges, those whose dihedral angle (between the two triangles' normals)
/// exceeds `crease_angle`; the pieces it falls into are its groups (one crease alone does not
/// cut a closed fan). A fan left whole whose vertex normal (`normals`, #V unit) is within
/// `max_angle` of each of its triangles keeps that normal at all its corners: a smooth surface
/// does not change. Every other group gets the angle-weighted normal of its triangles, and a
/// group with a triangle more than `max_angle` from that is cut further at its sharpest edges
/// until none is (at worst a triangle alone: its own normal). Triangles of zero area join
/// their neighbours' group and are not measured. Angles in degrees, crease_angle in (0, 180].
struct SplitNormals {
  std::vector<std::array<glm::vec3, 3>> corner_normals;  ///< #F × 3 unit normals; empty when every corner keeps its vertex normal
  std::size_t split_vertices = 0;  ///< vertices whose fan was split
  std::size_t extra_normals = 0;   ///< groups beyond one per vertex: the vertices the writers add for them
};
/// Cost: one pass over the corners (each fan's edges matched among its own corners).
SplitNormals split_vertex_normals(const Mesh& mesh, const VertexCorners& corners, std::span<const glm::dvec3> normals,
                                  double crease_angle, double max_angle = 80.0);

/// angle_weighted_normals recomputed at `vertices` only (any order, repeats allowed), after
/// they or their neighbours moved: the same values as the whole, in one pass over the triangles.
/// `triangles`, when given, holds (in increasing order) every triangle at those vertices,
/// and only those are visited.
void update_normals(Mesh& mesh, std::span<const std::uint32_t> vertices, std::span<const std::uint32_t> triangles = {});

/// Generalized winding number of the mesh's triangles about p: the solid angles they span
/// there (core/math.h solid_angle), summed in triangle order, over 4 pi. For a closed,
/// outward-oriented mesh 1 inside, 0 outside, 2 inside two overlapping parts.
double winding_number(const Mesh& mesh, const glm::dvec3& p);

/// How the ray from p in a fixed direction (away from the axes and diagonals) crosses the
/// triangle (a, b, c): +1 leaving through its front (where its normal (b - a) x (c - a)
/// points), -1 entering, 0 missing, or kRayAmbiguous where the ray passes within rounding of
/// an edge or p lies (nearly) in the triangle. Summed over a closed surface: its winding
/// number about p.
constexpr int kRayAmbiguous = 2;
int ray_crossing(const glm::dvec3& a, const glm::dvec3& b, const glm::dvec3& c, const glm::dvec3& p);

/// Whether p lies inside a closed, outward-oriented mesh: winding number at least 1/2, found
/// as the signed count of the mesh's crossings with a ray from p (for a closed surface the
/// winding number is that integer, overlapping parts included). Where the ray passes within
/// rounding of an edge or p lies (nearly) on a triangle, it decides by winding_number(). Many
/// times faster than winding_number() (no trigonometry). Precondition: every edge is shared
/// by exactly two triangles, in opposite directions.
bool inside_closed_mesh(const Mesh& mesh, const glm::dvec3& p);

/// inside_closed_mesh for many points at once (the same answers), in one pass over the
/// triangles: the points are binned by their shadow on a plane across the ray direction, and
/// each triangle is tested against the points whose shadow lies in its shadow's box. 1 inside,
/// 0 outside, per point (docs/defaults.md: why the points are binned, not the triangles).
std::vector<std::uint8_t> inside_closed_mesh(const Mesh& mesh, std::span<const glm::dvec3> points);

/// The winding number of a closed, outward-oriented mesh about each point, by the same ray
/// crossings as inside_closed_mesh (where ambiguous, the generalized winding number rounded):
/// 1 inside, 0 outside, 2 inside two overlapping parts, -1 inside a part turned inside out.
std::vector<int> winding_numbers(const Mesh& mesh, std::span<const glm::dvec3> points);

/// Float grid: the .glb and .gltf store positions as float32 offsets from an origin kept in
/// double precision, so a mesh free of self-intersections in double precision may intersect
/// itself once exported (seen on two sample skeletons; docs/defaults.md). The meshing stage therefore puts every vertex on a grid of spacing
/// `float_grid(reach)`, a power of two small enough that every offset of at most `reach`
/// between two grid points is a float32 (at most 2^24 steps), and the exporter puts its origin
/// on a grid of `export_grid_spacing` (a coarser power of two): the exported offsets are the
/// positions exactly. `reach` > 0 (twice the largest half extent of the mesh, for margin).
double float_grid(double reach);
/// The spacing of the grid the exporter puts its origin on, for a mesh of largest half extent
/// `half_extent`: 16 times float_grid(half_extent), a multiple of float_grid(reach) for any
/// reach up to 8 times `half_extent`.
double export_grid_spacing(double half_extent);
/// p rounded to the nearest multiple of `spacing` (a power of two) in each coordinate.
glm::dvec3 snap_to_grid(const glm::dvec3& p, double spacing);

}  // namespace sm
