#pragma once
/// Rotation-minimizing cross-section frames.

#include "skeleton/skeleton.h"

namespace sm {

/// The branch direction at node n: at the root, towards its main child; at a tip, along
/// its incoming edge; elsewhere the bisector of the incoming edge and the edge to the main
/// child (falling back to the incoming edge when the two are opposite).
dvec3 node_tangent(const Skeleton& skeleton, NodeId n);

/// Sets `skeleton.frame` for every node: the root gets a deterministic frame around its
/// tangent (normal as close to the world x axis as possible), every other node the frame of
/// its parent transported by the minimal rotation onto its own tangent, so 2D coordinates on
/// consecutive cross-sections do not twist (parallel transport, as Clasping Trees §4.1.2 does). At a fork
/// both children start from the parent's frame. Iterative (no recursion over depth).
void compute_frames(Skeleton& skeleton);

}  // namespace sm
