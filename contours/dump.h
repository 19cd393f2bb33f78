#pragma once
/// JSON dump of a contour set, written by `strandmesh mesh --dump-stages DIR` (contours.json)
/// and read back by the viewer.
///
/// Format (one JSON object; written compact, numbers with full double precision):
/// ```
/// {
///   "loops": [{                       // in loop order
///     "node": n, "t": t,              // the slice lies on the edge (parent(n), n) at parameter t
///     "kind": "plain" | "fused" | "split" | "tip",
///     "distance": d, "radius": r,     // metres
///     "center": [x, y, z],            // metres
///     "strands": [ints],              // per vertex: its strand, -1 for none
///     "points": [[x, y, z], ...]}],   // per vertex, metres
///   "tubes": [{"loops": [ints], "branch": n,
///              "start_junction": j, "end_junction": j}],      // -1 for none
///   "junctions": [{"fork": n, "lower": loop, "upper": [loop, loop],
///                  "split_distance": d, "forced": bool}]
/// }
/// ```
/// Not stored, recomputed on reading: the loop frames, the junctions' tube indices and
/// `lower_side`.

#include <string>

#include "contours/contours.h"
#include "particles/particles.h"
#include "skeleton/skeleton.h"

namespace sm {

/// The contour set as JSON text (format above).
std::string contours_to_json(const ContourSet& contours);

/// Parses the format above for `skeleton` (the one the contours were computed on). What the
/// file does not store is recomputed: the loop frames from the skeleton, and, when `field` is
/// given, each junction's `lower_side` from the particle order at the fork (as the contours
/// stage derives it). `name` names the source in errors. Throws InvalidInputError naming the
/// key on malformed input.
ContourSet contours_from_json(const std::string& text, const Skeleton& skeleton, const std::string& name,
                              const ParticleField* field = nullptr);

}  // namespace sm
