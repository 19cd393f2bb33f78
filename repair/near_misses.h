#pragma once
/// Step 3 of the repair stage, near misses: thick skeleton nodes (radius at least the median,
/// as `strandmesh check` counts them) that end up a little outside the finished mesh, and a
/// local push of the surface over each (RepairParams::cover_near_misses).
///
/// Where a twig leaves a fork at a steep angle or off a thick trunk, the crotch's loops can
/// pass a fraction of the twig's radius on the wrong side of a node at its base. The fork
/// retry re-slices the forks around them, but on a large tree each of its runs costs most of a
/// second, and the outer surface's sphere union a whole-mesh CGAL run.
/// Here the surface nearest the node is moved instead, no triangle added or removed:
///  - the nearest point q of the surface (at most kMaxMiss x the node's radius away: farther
///    is not a near miss) and the direction from q to the node;
///  - the corners of the triangle holding q move in that direction by the miss plus a margin
///    (a quarter of the radius, else a tenth, else 0.03, the first that passes the checks
///    below: q passes the node by that margin), and the vertices around q joined to
///    them over the surface less with their distance from q, to nothing at the radius plus
///    twice that move (smoothstep), each onto the float grid (MeshResult::grid);
///  - the push is kept if no triangle it moves turns over or degenerates, the triangles near
///    the moved ones have no more self-intersecting pairs than before (exact tests,
///    intersections.h), the node is then inside and no thick node near it has left (the
///    crossings of a ray change only at the moved triangles: core/mesh.h ray_crossing, with
///    inside_closed_mesh where that is ambiguous or a node may have left); otherwise its
///    vertices go back.
/// A push whose neighbourhood overlaps an earlier one's waits for the next round (up to 4).
/// Normals are recomputed at the vertices of the moved triangles (core/mesh.h update_normals);
/// UVs stay. Every mesh pays one inside test of every thick node. The triangles within kGather
/// radii of each node outside are gathered in one pass; the pushes' neighbourhoods come from
/// them where they fit.

#include <cstddef>
#include <string>

#include "meshing/meshing.h"
#include "skeleton/skeleton.h"

namespace sm {

struct NearMissStats {
  bool tried = false;              ///< RepairParams::cover_near_misses was on
  std::size_t outside_before = 0;  ///< thick nodes outside the mesh given
  std::size_t outside_after = 0;   ///< thick nodes outside the mesh kept
  std::size_t covered = 0;         ///< pushes kept
  std::size_t refused = 0;         ///< pushes undone (a triangle turned, a new crossing, a node left or not reached)
  std::size_t moved_vertices = 0;  ///< vertices moved by the pushes kept
  std::vector<NodeId> left;        ///< the thick nodes still outside (outside_after of them)
  double seconds = 0;
};

/// One line of the figures ("1 -> 0 thick nodes outside, ..."), for `strandmesh -v mesh` and
/// the viewer.
std::string to_text(const NearMissStats& stats);

/// Pushes the surface of `result`'s mesh over the thick nodes of `skeleton` (the sanitized
/// skeleton the mesh was made from) just outside it, as above. No push adds a pair, so the
/// pairs counted before (Crossings) still hold.
NearMissStats cover_near_misses(MeshResult& result, const Skeleton& skeleton);

}  // namespace sm
