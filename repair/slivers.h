#pragma once
/// \file slivers.h
/// The last step of the repair stage: slivers (triangles with an angle under `angle`, 10
/// degrees by default) removed by edge flips and edge collapses. The strips stitch loops whose strands crowd or
/// whose vertices nearly line up, and the repairs cut and move triangles; both leave needles
/// (one edge much shorter than the others) and caps (one angle near 180 degrees), which shade
/// as streaks in a close-up and make vertex normals that face away from a triangle.
///
/// Each sliver, in triangle order, first tries a flip of one of its edges (the one leaving the
/// larger smallest angle), then a collapse of one of its edges either way (the end kept stays;
/// among those leaving no sliver, the end farther from the skeleton's surface goes), else of
/// its shortest edge onto the midpoint on the float grid. (Collapses onto any near neighbour
/// removed more slivers but lost thick nodes from inside the willow.) Where none keeps the rules, a vertex of three neighbours at or next to
/// its vertices is collapsed first (a cut line passing a vertex leaves such near-coincident
/// vertices, which block every one-edge edit by the link condition) and the slivers that
/// leaves are flipped or collapsed in the same edit. An edit is kept only when
///  - the mesh stays a closed, oriented 2-manifold (the collapse's link condition: the edge's
///    ends share exactly its two opposite vertices, each keeps at least three neighbours);
///  - the smallest angle of the triangles it changes grows;
///  - no triangle turns by more than `max_turn` (a flip: against the pair's area-weighted
///    normal; a collapse: no triangle turns over and each is within `max_turn` of a normal of
///    the well-shaped triangles it changes, except across an edge under a hundredth of those
///    around it, which joins two vertices standing for one point), so the surface stays
///    where it was within the sliver's size;
///  - the corner UVs follow: carried around the moved vertex through seams where the two
///    sides differ by a translation (u's wrap), and past other seams (charts meeting at a
///    fork or a cut line) given by the map of the best-shaped triangle of that side; no
///    triangle's texture turns over where it had one side;
///  - its triangles take part in no more self-intersecting pairs than before (exact tests,
///    sm_meshcheck's TriangleIntersections, against the triangles near them on a grid; the
///    mesh's pairs are found once and kept up to date);
///  - no point to keep inside (the thick skeleton nodes) that is inside the mesh leaves it: the
///    winding number about a point changes only by that of the closed surface the edit's new
///    triangles and its old ones reversed make, so only the points in those triangles' box are
///    tested, against them alone (ray crossings as inside_closed_mesh counts them).
///  - beyond the needles' phase (below), no vertex the edit removes or moves, nor the old
///    edge of a flip, lies farther than `max_move` local radii from the surface after it: on
///    a twig a few vertices around, collapsing a mild sliver's short edge would flatten it.
/// Two phases where `angle` is over a degree: the needles (under a degree) first, then the
/// rest, so that edits on milder slivers do not take the neighbourhoods the needles need;
/// within a round the thinnest go first.
/// Edits in one round touch disjoint vertices; rounds repeat while any edit is kept or undone,
/// and an edit undone for its crossings or refused for a point is not tried again (its sliver
/// tries the next best).
/// A round costs the tests near its edits, not a pass over the mesh: a sliver no edit could
/// remove is looked at again only where a kept edit changes a triangle at one of its vertices.
/// Deterministic: slivers are visited in triangle order, serially.

#include <cstddef>
#include <array>
#include <span>
#include <vector>

#include "meshing/meshing.h"
#include "skeleton/skeleton.h"

namespace sm {

struct SliverOptions {
  double angle = 1.0;         ///< a sliver has an angle under this (degrees; 0 = none removed)
  double max_turn = 30.0;     ///< largest turn of a changed triangle's normal (degrees)
  int max_rounds = 64;        ///< rounds of finding slivers and editing them (count)
  /// The mesh's self-intersecting pairs, sorted, where the caller knows them all (none: an
  /// empty list), or null: they are searched for. (Were the list short of some, edits near
  /// them would only be refused.)
  const std::vector<std::array<std::uint32_t, 2>>* known_pairs = nullptr;
  /// Per vertex (#V, or empty): how far it lies from the surface it stands for (any unit). A
  /// collapse keeps the edge's end with the smaller value where it can.
  std::span<const double> vertex_error;
  /// Per vertex (#V, or empty): the local radius of the branch it lies on (cone_radius).
  std::span<const double> vertex_radius;
  /// An edit is refused where a vertex it removes, moves or unlinks lies farther than this
  /// share of the local radius from the surface after it: on a twig of a few vertices around,
  /// collapsing a needle's short edge would flatten the twig (0 = no limit).
  double max_move = 0.1;
  /// Points that must stay inside the mesh where they are inside it (the thick skeleton
  /// nodes): an edit that would leave one of them outside is refused.
  std::span<const glm::dvec3> keep_inside;
};

/// Per vertex of `mesh` (#V): its distance from the round cone of the skeleton edge that made
/// it (Mesh::vertex_node and its parent) over the local radius; 0 without vertex_node.
std::vector<double> cone_error(const Mesh& mesh, const Skeleton& skeleton);

/// Per vertex of `mesh` (#V): the radius of the round cone of the skeleton edge that made it at
/// its nearest point (0 without vertex_node).
std::vector<double> cone_radius(const Mesh& mesh, const Skeleton& skeleton);

struct SliverStats {
  std::size_t found = 0;      ///< slivers before the step
  std::size_t flips = 0;      ///< edge flips kept
  std::size_t collapses = 0;  ///< collapse edits kept (each removes a vertex and two triangles; one after a vertex of three neighbours, two of each)
  std::size_t undone = 0;     ///< edits undone because their triangles crossed others
  std::size_t kept_out = 0;   ///< edits refused because they would leave a point of keep_inside outside
  std::size_t left = 0;       ///< slivers after the step
  std::size_t rounds = 0;     ///< rounds run
};

/// Removes slivers from `mesh` in place (MeshResult::grid kept). The triangles collapses remove
/// are left as (u, u, u) for the caller to drop; the vertices they remove are no longer used.
/// Normals are not updated. Precondition: `mesh` is closed, edge-manifold and oriented.
SliverStats remove_slivers(MeshResult& mesh, const SliverOptions& options = {});

}  // namespace sm
