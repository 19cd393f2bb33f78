#pragma once
/// JSON dump of the strand curves, for the viewer, tests and `strandmesh particles` (and later
/// `strandmesh mesh --dump-stages`). It lives beside strands/ rather than in particles/dump.h
/// because it needs the StrandSet (particles/ cannot depend on strands/).
///
/// Format (one JSON object; arrays flattened; #N nodes, #P particles, #S strands; particle
/// (n, j) has global index g = node_begin[n] + j, as in the particles dump):
/// ```
/// {
///   "format": "strandmesh-strands", "version": 1,
///   "alpha": 0.5,                    // Catmull-Rom knot exponent
///   "nodes": N, "particles": P, "strands": S,
///   "node_begin":     [N+1 ints],    // as in the particles dump
///   "strand":         [P ints],      // strand id of each particle
///   "parent_global":  [P ints],      // global index of the same strand's point at the parent
///                                    // node; -1 at the root
///   "strand_start":   [S ints],      // start node of each strand
///   "start_global":   [S ints],      // global index of each strand's first (tip-most) point
///   "point":          [3P numbers],  // world position of each particle, metres
///   "tangent":        [3P numbers],  // Hermite tangent at g's end (t = 1) of the edge
///                                    // parent(n) -> n, metres per unit t (zeros at the root)
///   "tangent_parent": [3P numbers],  // Hermite tangent at the parent end (t = 0)
///   "stats": {"strands", "segments", "timings": {...}, "warnings": [...]}
/// }
/// ```
/// Segment of g on the edge parent(n) -> n, for t in [0, 1] (t = 0 at the parent):
///   P(t) = (2t^3 - 3t^2 + 1) A + (t^3 - 2t^2 + t) tangent_parent[g]
///        + (-2t^3 + 3t^2) B + (t^3 - t^2) tangent[g],
/// with A = point[parent_global[g]] and B = point[g]. A strand is followed from
/// start_global[s] through parent_global to the root.

#include <string>

#include "particles/particles.h"
#include "skeleton/skeleton.h"
#include "strands/strands.h"

namespace sm {

/// The strands as JSON text (format above). `params` only records alpha.
std::string strands_to_json(const Skeleton& skeleton, const ParticleField& field, const StrandSet& strands,
                            const StrandParams& params = {});

}  // namespace sm
