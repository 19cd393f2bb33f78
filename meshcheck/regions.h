#pragma once
/// Internal to meshcheck: where a mesh's caps and junctions are, from its skeleton (the
/// definitions of quality.h), shared by the triangle quality and the UV figures.

#include <cstdint>
#include <memory>
#include <vector>

#include "core/mesh.h"
#include "meshcheck/cone_tree.h"
#include "skeleton/skeleton.h"

namespace sm::detail {

/// Per vertex (#V): the end (tip node + 1, or the root + 1) whose cap it belongs to, else 0
/// (quality.h: caps).
std::vector<std::uint32_t> cap_ends(const Mesh& mesh, const Skeleton& skel);

/// Whether each triangle (#F) is a cap triangle: its three vertices are cap vertices of one end.
std::vector<std::uint8_t> cap_triangles(const Mesh& mesh, const std::vector<std::uint32_t>& cap_end);

/// A ball of `junction_radii` x its radius around every node with two or more children
/// (Cone::id: the node); a point is at a junction where nearest(p).distance <= 0. Null
/// when the skeleton has no fork.
std::unique_ptr<ConeTree> junction_balls(const Skeleton& skel, double junction_radii);

}  // namespace sm::detail
