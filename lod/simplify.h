#pragma once
/// Simplification that keeps a clean mesh clean: edge collapses that leave a closed, manifold,
/// consistently oriented mesh free of self-intersections as it was, down to a triangle count.
///
/// Each step collapses one edge into one of its ends (a half-edge collapse: the kept vertex
/// does not move, so positions stay on the mesh's float grid, core/mesh.h), cheapest first by
/// the quadric error of the planes around both ends (Garland and Heckbert, "Surface
/// Simplification Using Quadric Error Metrics"). A collapse is made only when
///  - the edge has exactly two triangles and the ends share no neighbour but their two
///    opposite vertices (the link condition: the mesh stays a closed 2-manifold);
///  - no triangle that moves turns its normal by more than `max_normal_turn` or becomes
///    (nearly) degenerate;
///  - no triangle that moves intersects any other triangle (exact predicates, the test of
///    `strandmesh check`), checked when the collapse is made, against the mesh as it is then.
/// So a mesh without self-intersecting pairs stays without; pairs it starts with may remain.
/// (OpenMesh's and meshoptimizer's simplifiers judge a collapse when it enters their queue,
/// before the collapses made around it meanwhile, which is why this one is ours.)
///
/// Attributes: the kept vertex keeps its node, strand and normal; the moved corners take the
/// kept vertex's UV in their own chart (its offset from the removed vertex, taken from a
/// removed triangle in the same chart); triangles keep their branch id. Normals, when the mesh
/// has them, are recomputed (angle-weighted, one per vertex: corner normals are dropped;
/// repair/repair.h finish_normals makes them again). Deterministic, single-threaded.

#include <cstddef>

#include "core/mesh.h"

namespace sm {

struct SimplifyParams {
  std::size_t target_triangles = 0;  ///< stop at or below this many triangles (a count; unreachable targets stop where no collapse is allowed)
  double max_normal_turn = 60.0;     ///< largest turn of a moved triangle's normal (degrees)
  double min_sine = 1e-3;            ///< a moved triangle's smallest angle must have at least this sine (about 0.06 degrees)
};

struct SimplifyStats {
  std::size_t triangles_before = 0;
  std::size_t triangles_after = 0;
  std::size_t collapses = 0;               ///< edges collapsed
  std::size_t refused_topology = 0;        ///< collapses refused by the link condition
  std::size_t refused_shape = 0;           ///< refused for a turned or degenerate triangle
  std::size_t refused_intersection = 0;    ///< refused because a moved triangle would cross another
  std::size_t pairs_after = 0;             ///< self-intersecting pairs of the result (whole mesh)
};

/// `mesh` simplified to at most `params.target_triangles` triangles where the rules above allow.
/// Precondition: `mesh` is closed, edge-manifold and oriented (every edge in two triangles, in
/// opposite directions); edges where that does not hold are never collapsed.
Mesh simplify_mesh(const Mesh& mesh, const SimplifyParams& params, SimplifyStats* stats = nullptr);

}  // namespace sm
