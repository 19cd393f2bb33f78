#pragma once
/// Strands stage: one centripetal Catmull-Rom curve per strand, from its start node (a tip or
/// the node where it was added) down to the root, through the 3D positions of its particles.
///
/// A particle's 3D point is `position[n] + frame[n].to_world(p)`. Curves are evaluated per
/// edge: the edge of node n (n != root) goes from parent(n) (t = 0) to n (t = 1), in growth
/// direction, and for each local particle j of n the segment of its strand on that edge is a
/// cubic Hermite piece whose end tangents come from the centripetal Catmull-Rom rule
/// (alpha = 0.5: no cusps or self-loops) using the strand's neighbouring points (the point at
/// the grandparent and the point in the child along the strand; at the ends of a strand the
/// missing neighbour is mirrored). Only the points are stored; StrandSet::tangents computes a
/// segment's tangents from them.

#include <cstdint>
#include <vector>

#include "core/param_table.h"
#include "core/ids.h"
#include "core/math.h"
#include "core/report.h"
#include "particles/particles.h"
#include "skeleton/skeleton.h"

namespace sm {

struct StrandParams {
  /// Catmull-Rom parameterization exponent in [0, 1]: 0 uniform, 0.5 centripetal (default:
  /// no cusps or self-loops), 1 chordal.
  double alpha = 0.5;
};

/// The config key, accepted range, unit and help of each field of StrandParams, in header order
/// (core/param_table.h; the defaults are the initializers above).
const ParamTable<StrandParams>& param_table(std::type_identity<StrandParams>);

struct StrandStats {
  std::size_t strands = 0;
  std::size_t segments = 0;  ///< one per particle of a non-root node
  Warnings warnings;
  Timings timings;
};

/// The Hermite end tangents of one strand segment (metres per unit t of the segment).
struct SegmentTangents {
  dvec3 at_parent{0.0};     ///< at t = 0, the parent's end of the edge
  dvec3 at_node{0.0};       ///< at t = 1, the node's end
  bool degenerate = false;  ///< the segment's two end points coincide (both tangents zero)
};

/// All strand curves (indexed like ParticleField: #P entries, particle (n, j) at
/// field.global(n, j)). A curve is its points and the Catmull-Rom rule: each segment's
/// tangents follow from four points of its strand (SegmentTangents), computed where a curve
/// is evaluated rather than stored. Only the viewer, the dumps and sample_strand evaluate
/// curves; the contours slice the particles' cross-section positions, and two stored tangents
/// per particle were 80 MB and two thirds of this stage's time on the large grown tree.
struct StrandSet {
  std::vector<dvec3> point;  ///< #P 3D point of each particle (metres, world)
  double alpha = 0.5;        ///< the knot exponent of the curves (StrandParams::alpha)
  StrandStats stats;

  /// The end tangents of local particle j of node n's strand on n's edge.
  /// Precondition: n is not the root.
  [[nodiscard]] SegmentTangents tangents(const Skeleton& s, const ParticleField& f, NodeId n, std::uint32_t j) const;
  /// Point of local particle j of node n's strand on n's edge at t in [0, 1]
  /// (t = 0: at parent(n), t = 1: at n). Precondition: n is not the root.
  [[nodiscard]] dvec3 evaluate(const Skeleton& s, const ParticleField& f, NodeId n, std::uint32_t j, double t) const;
  /// Derivative d/dt of evaluate().
  [[nodiscard]] dvec3 derivative(const Skeleton& s, const ParticleField& f, NodeId n, std::uint32_t j, double t) const;
};

/// Builds every strand's curve (parallel over nodes; identical for any thread count).
/// Precondition: `field` was computed for `skeleton`. Throws InvalidInputError when alpha is
/// outside [0, 1]. A segment whose two end points coincide gets zero tangents (counted
/// warning "degenerate_segment").
StrandSet build_strands(const Skeleton& skeleton, const ParticleField& field, const StrandParams& params = {});

/// The nodes a strand passes through, from its start node down to the root (#K), and its
/// local particle index at each (#K).
/// Throws InternalError when the strand id is out of range.
struct StrandPath {
  std::vector<NodeId> nodes;
  std::vector<std::uint32_t> local;
};
StrandPath strand_path(const Skeleton& skeleton, const ParticleField& field, StrandId strand);

/// A polyline sampling of one strand, tip to root, with `samples_per_edge` points per edge
/// (plus the root), and the cumulative arc length at each sample (metres).
struct StrandPolyline {
  std::vector<dvec3> points;
  std::vector<double> arc_length;
};
StrandPolyline sample_strand(const Skeleton& skeleton, const ParticleField& field, const StrandSet& strands,
                             StrandId strand, int samples_per_edge = 8);

/// The point at arc length `s` (metres from the strand's start, clamped to the strand) of a
/// sampled strand, linearly interpolated between samples.
dvec3 point_at_arc_length(const StrandPolyline& polyline, double s);

}  // namespace sm
