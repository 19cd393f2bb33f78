#pragma once
/// The genus a skeleton implies: where branches cross or touch away from a shared node, the
/// union of their volumes has handles, and a faithful mesh of that union has that genus.
/// `strandmesh check --skeleton` reports it beside the mesh's genus.
///
/// Model: every edge is a round cone (the convex hull of its two end spheres; radii as given,
/// so call it on `input_skeleton()`, which raises radii below the floor to it). The union of
/// convex sets is homotopy equivalent to the nerve of the cover (nerve theorem), so its first
/// Betti number b1 (over Z2) is the nerve's: vertices the cones, edges the pairs that meet,
/// triangles the triples with a common point. For a solid without inner voids whose boundary
/// is one closed surface, that surface's genus is b1; the result is b1.
///
/// What is exact and what is not:
///  - Cones that share a node always meet, and all cones at a node have the node's centre in
///    common: each node's cones are one filled simplex, handled implicitly (a hub of a thousand
///    twigs costs nothing). Only cones without a shared node that meet ("crossing pairs") and
///    the triangles they are in are tested.
///  - Whether two or three cones have a common point is decided exactly up to
///    `contact_tolerance`: a witness point inside all of them, or a certificate that none
///    exists (a deep-cut ellipsoid search on the largest signed distance, convex), not the
///    closest points of the axes. Cones closer than the tolerance count as meeting; tangency
///    within a few tolerances is decided either way.
///  - b2 (voids enclosed by crossing branches) is not counted; the mesh drops inner shells.
///  - Near tangency, and around holes thinner than a fraction of a radius (a tight crotch), the
///    cones have handles no mesh should copy: `robust_genus` counts only the handles that hold
///    from radii x (1 - robust_margin) to x (1 + robust_margin), persistent homology's rank of
///    the map between the two unions' H1, computed in the larger union's reduction.
///
/// Cost: candidate pairs by CGAL's box intersection (O(n log n) on trees); then per crossing
/// pair its triangles, found from the crossing pairs of its two cones (O(sum of squared
/// crossing degrees)); a triangle is tested only when it can still lower b1 (union-find over
/// the crossing pairs, then a sparse Z2 elimination for triangles of three crossing pairs).
/// The 1,000,000-node chain of 1 cm steps and 2 cm radii (3 M crossing pairs) takes seconds.
/// Capped: the iterative searches (`max_searches`; past it the undecided triangles make the
/// result a range [genus_min, genus]), the triangle candidates listed (`max_listed`; past it
/// the range starts at 0) and the candidate pairs kept (`max_candidates`; past it no result). The robust genus runs the same at two more
/// radius scales (only when the genus is not 0). Pair tests run in parallel (oneTBB); the
/// result is the same for any thread count.

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "skeleton/skeleton.h"

namespace sm {

/// Options of implied_genus.
struct ImpliedGenusParams {
  double contact_tolerance = 1e-6;      ///< cones this close count as meeting (relative to the smallest radius involved; default 1e-6)
  std::size_t max_searches = 1'000'000;  ///< iterative searches for triangles at most (count; default 1e6); past it, a range
  std::size_t max_examples = 5;          ///< handles located in `handle_examples` (count; default 5)
  std::size_t max_candidates = 50'000'000;  ///< pairs of overlapping boxes without a shared node kept at most (count; default 5e7); past it, no result
  std::size_t max_listed = 500'000'000;     ///< triangle candidates listed at most (count; default 5e8); past it, genus_min is 0
  double robust_margin = 0.15;           ///< robust_genus: handles from radii x (1 - this) surviving to x (1 + this) (relative; 0 = skip; default 0.15)
};

/// What implied_genus found.
struct ImpliedGenus {
  std::int64_t genus = 0;           ///< b1 of the union of the round cones (the upper end of the range when not exact)
  std::int64_t genus_min = 0;       ///< the lower end: equal to genus unless the search cap was reached
  /// The handles that do not hinge on tangency or on a hole thinner than the margin: the rank of
  /// H1(union at radii x (1 - robust_margin)) -> H1(union at x (1 + robust_margin)). Any solid
  /// between those two unions has at least this genus.
  std::int64_t robust_genus = 0;
  std::size_t cones = 0;            ///< one per edge
  std::size_t candidate_pairs = 0;  ///< pairs of cones without a shared node whose boxes overlap
  std::size_t crossing_pairs = 0;   ///< of those, the pairs that meet
  std::size_t triangles_tested = 0; ///< triples of cones tested for a common point
  std::size_t searches = 0;         ///< tests that needed the iterative search (no cheap witness or bound)
  std::size_t undecided = 0;        ///< triangles left untested past max_searches
  /// One crossing pair per handle, up to max_examples: the child nodes of the two edges (node
  /// indices), ascending. Which pair stands for a handle is a choice where loops share pairs.
  std::vector<std::array<std::uint32_t, 2>> handle_examples;
  double seconds = 0;               ///< wall time
  /// False when more than max_candidates pairs of boxes overlap (a tangle no mesh is made of):
  /// no figure was computed, the genus fields are 0.
  bool complete = true;

  [[nodiscard]] bool exact() const { return genus == genus_min; }
};

/// The genus implied by the round cones of `skeleton`'s edges (any number of children per node,
/// any node order: uses `position`, `radius` and `parent` only). Radii must be finite and >= 0
/// (0 makes a cone a segment) and positions finite; a skeleton without edges has genus 0.
ImpliedGenus implied_genus(const Skeleton& skeleton, const ImpliedGenusParams& params = {});

}  // namespace sm
