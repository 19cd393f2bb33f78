#pragma once
/// JSON dump of a particle field, for the viewer, tests and `strandmesh particles` (and later
/// `strandmesh mesh --dump-stages`).
///
/// Format (one JSON object; arrays flattened; #N nodes, #P particles, #S strands):
/// ```
/// {
///   "format": "strandmesh-particles", "version": 1,
///   "spacing": s,                     // metres
///   "neighbour_distance": d,          // metres, typical neighbour distance at nominal density
///   "nodes": N, "particles": P, "strands": S,
///   "node_begin":   [N+1 ints],       // node n owns particles [node_begin[n], node_begin[n+1])
///   "new_begin":    [N ints],         // local index of the first strand that starts at n
///   "steps":        [N ints],         // relaxation steps at n
///   "disc_radius":  [N numbers],      // metres: the disc the particles of n are confined to
///   "position":     [2P numbers],     // x0, y0, x1, y1, ...: 2D in the node frame
///                                     // (x along frame.normal, y along frame.binormal), metres
///   "strand":       [P ints],         // strand id of each particle
///   "strand_begin": [N+1 ints],       // strands [strand_begin[n], strand_begin[n+1]) start at n
///   "strand_start": [S ints],         // start node of each strand
///   "stats": {"nodes", "strands", "particles", "new_strands", "relaxation_steps",
///             "relaxed_nodes", "relaxed_particles", "unconverged_nodes",
///             "timings": {name: seconds}, "warnings": [{"kind", "message", "count", "examples"}]}
/// }
/// ```
/// The 3D point of particle (n, j) is skeleton.position[n] + frame[n].to_world(p); the strands
/// dump (strands/dump.h) has it precomputed. Numbers are written with full double precision.

#include <string>

#include "particles/particles.h"
#include "skeleton/skeleton.h"

namespace sm {

/// The particle field as JSON text (format above). `skeleton` is the one the field was
/// computed for (used only for the node count check).
std::string particles_to_json(const Skeleton& skeleton, const ParticleField& field);

/// Parses the format above back into a field (stats: counts, no timings or warnings).
/// Throws InvalidInputError naming the key when the text is not such a dump.
ParticleField particles_from_json(const std::string& text);

}  // namespace sm
