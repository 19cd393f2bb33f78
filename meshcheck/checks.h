#pragma once
/// Mesh checks: is a mesh a closed, oriented, genus-0 2-manifold without degenerate faces or
/// self-intersections, and (given the skeleton) does its surface follow the skeleton's radii?
/// The library side of `strandmesh check`.
///
/// Definitions (V, E, F count vertices used by a triangle, undirected edges, triangles):
///  - boundary edge: used by exactly one triangle; closed = no boundary edges.
///  - non-manifold edge: used by three or more triangles; edge-manifold = none.
///  - non-manifold vertex: its triangles form more than one fan (connected through edges at
///    the vertex); vertex-manifold = none. Only meaningful on edge-manifold meshes.
///  - misoriented edge: an edge with two triangles that traverse it in the same direction;
///    oriented = none (and edge-manifold).
///  - components: connected components of the triangles through shared vertices.
///  - Euler characteristic χ = V - E + F; genus = (2 C - χ) / 2 summed over the C components,
///    defined only for closed, manifold, oriented meshes.
///  - degenerate triangle: a repeated vertex index, or an area at most
///    `degenerate_area_ratio` × (bounding-box diagonal)² (zero-area triangles included).
///  - signed volume: Σ det(p0, p1, p2) / 6 over triangles (positive when the triangles face
///    outward), computed relative to the bounding-box centre so large coordinates do not
///    cancel.
///  - self-intersection: a pair of non-degenerate triangles that intersect other than in the
///    vertex or edge they share in the connectivity (CGAL Polygon Mesh Processing
///    `self_intersections` on the mesh when the triangles form a valid polygon mesh, otherwise
///    the same test on the triangle soup with CGAL's box intersection; exact predicates).
///  - fidelity (with a skeleton): for every mesh vertex, the distance to the skeleton's
///    round-cone surface (union over edges of the convex hull of the two end spheres; a single
///    node is a sphere) divided by the radius of the nearest cone at the closest point
///    (linearly interpolated between its end radii); reported as p50, p95 and max.
///  - thick nodes inside (with a skeleton): every node whose radius is at least the median
///    radius must lie inside the mesh or on its surface (a node at the centre of a flat cap):
///    winding number at least 1, all nodes in one pass over the triangles (core/mesh.h
///    winding_numbers), or on the surface by CGAL's exact `Side_of_triangle_mesh`; only
///    tested on a closed, manifold, oriented mesh. A node inside two overlapping parts, where
///    the mesh intersects itself, has winding number 2 and is inside
///    (thick_nodes_in_overlaps; the self-intersections are reported anyway).
///  - implied genus (with a skeleton, on request): the genus of the union of the skeleton's
///    round cones, from where its branches cross or touch away from a shared node
///    (meshcheck/implied_genus.h), and how many of those handles are robust: still there with
///    every radius scaled by 1 - fidelity_tolerance and not yet closed at 1 + fidelity_tolerance.
///    A solid whose surface keeps within that band of the round cones has at least the robust
///    genus. Informative: near tangency the round cones and the strands' surface differ, and
///    the check does not prove the band, so a mismatch is reported, not failed.
///
/// Cost: O(F log F) plus the self-intersection test (box intersection, near-linear on meshes
/// without many overlaps; parallel with oneTBB) and O(V log N) for fidelity with a bounding-
/// volume hierarchy over the skeleton's edges. The report is identical for any thread count.

#include <array>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "core/mesh.h"
#include "core/report.h"
#include "meshcheck/quality.h"
#include "meshcheck/uv_quality.h"
#include "skeleton/skeleton.h"

namespace sm {

/// The skeleton nodes check_mesh asks to lie inside the mesh: radius at least the median (the
/// lower median for an even count), in index order.
std::vector<std::uint32_t> thick_node_ids(const Skeleton& skeleton);

/// check_mesh's fidelity p95 alone (the same value, with check_mesh's default tolerance for
/// nothing else): for a repair that judges an edit by it, without the topology and the exact
/// tests a whole check costs. 0 where the skeleton is empty or a vertex is not finite.
double fidelity_p95(const Mesh& mesh, const Skeleton& skeleton);

/// Options of check_mesh.
struct MeshCheckParams {
  bool self_intersections = true;        ///< run the (most expensive) self-intersection test (default true)
  double degenerate_area_ratio = 1e-14;  ///< degenerate when area <= this × bbox diagonal² (relative; default 1e-14)
  const Skeleton* skeleton = nullptr;    ///< measure fidelity to this skeleton (mesh's frame); none by default
  double fidelity_tolerance = 0.15;      ///< ok() needs p95 fidelity <= this (relative to local radius; default 0.15)
  std::size_t max_examples = 5;          ///< offending edges/triangles/pairs listed per kind (count; default 5)
  bool quality = true;                   ///< measure triangle quality and backward normals (meshcheck/quality.h; default true)
  /// Hold the mesh to these quality goals (ok() fails where one is missed); none by default:
  /// the quality figures are informative.
  std::optional<QualityLimits> quality_limits;
  double junction_radii = QualityParams{}.junction_radii;  ///< junction edges: within this many fork radii of a fork
  bool uvs = true;  ///< measure UV seams and stretch where the mesh has UVs (meshcheck/uv_quality.h; default true)
  bool implied_genus = false;  ///< with a skeleton: also the genus its crossing branches imply (implied_genus.h; default false)
  std::size_t fidelity_worst = 0;  ///< with a skeleton: list this many vertices farthest from the round cones (count; default 0)
};

/// A vertex far from the skeleton's round cones, and where on the skeleton it is nearest.
struct FidelityVertex {
  std::uint32_t vertex = 0;  ///< mesh vertex index
  double deviation = 0;      ///< signed distance to the round cones / local radius (negative inside)
  std::uint32_t node = 0;    ///< skeleton node at the upper end of the nearest edge (its child end)
  double t = 0;              ///< along that edge, 0 at the parent's sphere, 1 at the node's
};

/// What check_mesh found. Counts are exact; `*_examples` list the first few offenders
/// (vertex pairs for edges, triangle indices otherwise) in index order.
struct MeshCheckReport {
  std::size_t vertices = 0;               ///< #V of the mesh, used or not
  std::size_t unreferenced_vertices = 0;  ///< vertices no triangle uses (informative)
  std::size_t nonfinite_vertices = 0;     ///< vertices with a NaN or infinite coordinate
  std::size_t triangles = 0;              ///< #F
  std::size_t edges = 0;                  ///< undirected edges
  std::size_t components = 0;             ///< connected components (through shared vertices)
  std::size_t boundary_edges = 0;         ///< edges with one triangle
  std::size_t nonmanifold_edges = 0;      ///< edges with three or more triangles
  std::size_t nonmanifold_vertices = 0;   ///< vertices whose triangles form several fans
  std::size_t misoriented_edges = 0;      ///< two-triangle edges traversed twice in the same direction
  bool closed = false;                    ///< no boundary edges
  bool edge_manifold = false;             ///< no non-manifold edges
  bool vertex_manifold = false;           ///< no non-manifold vertices
  bool oriented = false;                  ///< edge-manifold and no misoriented edges
  std::int64_t euler_characteristic = 0;  ///< V - E + F (V = used vertices)
  std::optional<std::int64_t> genus;      ///< total genus, for closed, manifold, oriented meshes
  std::size_t degenerate_triangles = 0;   ///< repeated index or (near-)zero area
  double min_triangle_area = 0;           ///< smallest triangle area (m²)
  double signed_volume = 0;               ///< m³; > 0 when triangles face outward
  double bbox_diagonal = 0;               ///< length of the bounding-box diagonal (m)

  bool self_intersections_checked = false;  ///< the self-intersection test ran
  std::size_t self_intersecting_pairs = 0;  ///< intersecting triangle pairs

  bool fidelity_checked = false;       ///< a skeleton was given
  double fidelity_p50 = 0;             ///< median |distance to round cones| / local radius
  double fidelity_p95 = 0;             ///< 95th percentile of the same
  double fidelity_max = 0;             ///< largest of the same
  double fidelity_tolerance = 0;       ///< the tolerance ok() applies to fidelity_p95
  std::size_t fidelity_outliers = 0;   ///< vertices farther from the round cones than the tolerance
  bool inside_checked = false;         ///< the thick-node inside test ran (closed manifold oriented mesh)
  std::size_t thick_nodes = 0;         ///< skeleton nodes with radius >= the median radius
  std::size_t thick_nodes_inside = 0;  ///< of those, how many lie inside the mesh (or on it)
  std::size_t thick_nodes_in_overlaps = 0;  ///< of those, inside overlapping parts (winding number >= 2)
  std::size_t nodes = 0;               ///< all skeleton nodes (with inside_checked)
  std::size_t nodes_inside = 0;        ///< of those, inside the mesh by winding number (a node on the surface may count out)
  bool implied_genus_checked = false;  ///< the skeleton's implied genus was computed
  std::int64_t implied_genus = 0;      ///< genus of the union of the skeleton's round cones (upper end when a range)
  std::int64_t implied_genus_min = 0;  ///< lower end (equal to implied_genus unless its search cap was reached)
  std::int64_t implied_genus_robust = 0;  ///< of those, the handles kept with radii x (1 -+ fidelity_tolerance)
  std::size_t crossing_pairs = 0;      ///< skeleton edges whose round cones meet without a shared node

  std::vector<std::array<std::uint32_t, 2>> boundary_edge_examples;      ///< vertex pairs
  std::vector<std::array<std::uint32_t, 2>> nonmanifold_edge_examples;   ///< vertex pairs
  std::vector<std::uint32_t> nonmanifold_vertex_examples;                ///< vertex indices
  std::vector<std::array<std::uint32_t, 2>> misoriented_edge_examples;   ///< vertex pairs
  std::vector<std::uint32_t> degenerate_triangle_examples;               ///< triangle indices
  std::vector<std::array<std::uint32_t, 2>> self_intersection_examples;  ///< triangle pairs
  std::vector<std::uint32_t> outside_node_examples;                      ///< skeleton node indices (thick, outside)
  std::vector<std::uint32_t> fidelity_outlier_examples;                  ///< vertex indices (beyond the tolerance)
  std::vector<FidelityVertex> fidelity_worst;  ///< the fidelity_worst vertices farthest from the cones, worst first
  std::vector<std::array<std::uint32_t, 2>> handle_examples;  ///< skeleton node pairs: the child nodes of two crossing edges, one per implied handle
  bool quality_checked = false;   ///< triangle quality was measured
  TriangleQuality quality;        ///< angles, aspect ratios, dihedral angles, backward normals
  std::optional<QualityLimits> quality_limits;  ///< the goals ok() applies to `quality`, if any
  bool uv_checked = false;        ///< the mesh has UVs and they were measured (informative)
  UvQuality uv;                   ///< seams and stretch of the UVs
  Timings timings;                                                       ///< seconds per phase

  /// True when every check passed: closed, edge- and vertex-manifold, oriented, one component
  /// (any genus: where branches cross, their union has a handle), no degenerate triangles, no non-finite vertices, no self-intersections (when
  /// checked), positive volume, and, when a skeleton was given, fidelity p95 <= tolerance and
  /// every thick node inside; with quality limits, those met too.
  [[nodiscard]] bool ok() const;
  /// Whether the mesh's genus equals the implied genus (lies in its range); empty when either
  /// is unknown.
  [[nodiscard]] std::optional<bool> genus_agrees() const;
  /// One short sentence per failed criterion ("3 boundary edges (not closed)"); empty when ok().
  [[nodiscard]] std::vector<std::string> failures() const;
};

/// Checks `mesh` (any Mesh; it need not be manifold). Throws InvalidInputError when a triangle
/// references a vertex that does not exist.
MeshCheckReport check_mesh(const Mesh& mesh, const MeshCheckParams& params = {});

/// A human-readable multi-line report (stable wording; ends with "result: ok" or "result: FAILED").
std::string to_text(const MeshCheckReport& report);

/// The report as JSON: every field above plus "ok" and "failures".
nlohmann::json to_json(const MeshCheckReport& report);

}  // namespace sm
