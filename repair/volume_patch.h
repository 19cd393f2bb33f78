#pragma once
/// Volume patch: the last resort for crossings the self-union could not judge (a tube turned
/// inside out over a section, branches running inside each other along their length). Around
/// each cluster of such pairs, a box-shaped region of the surface is cut out and replaced by
/// the boundary of the solid the surface wraps there, found on a voxel grid: voxels near the
/// surface form a wall, the voxels the wall separates from the box's outside (judged by the
/// winding number of the whole surface, so orientation does not matter) are solid, and
/// OpenVDB's volumeToMesh draws the surface between them. The patch is cut back from where
/// the kept surface runs and joined to it by a strip stitched between the two boundary loops.
///
/// A patch is kept only where it makes no new crossing, joins every loop it cut, and keeps the
/// anchors (skeleton nodes) inside; the cost of one grows with its region (its voxels are
/// bounded by `max_voxels`), not with the tree.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/mesh.h"

namespace sm {
struct Skeleton;
}

namespace sm {

struct VolumePatchOptions {
  double voxels_per_radius = 6;         ///< voxel size: the thinnest local radius over this
  double reach = 2.5;                   ///< region: the pairs' box grown by this many local radii
  std::size_t max_voxels = 3'000'000;   ///< largest grid of one patch (coarser voxels beyond)
  double min_voxels_per_radius = 2.5;   ///< a region whose thinnest radius gets fewer is not patched
  double grid = 0;                      ///< float grid of the positions (core/mesh.h), 0: none
  double adaptivity = 0;              ///< OpenVDB's: larger polygons where the surface is flat (0: none)
  bool allow_crossings = false;         ///< keep a patch that crosses (the caller untangles it)
};

struct VolumePatchStats {
  std::size_t clusters = 0;          ///< clusters of pairs found
  std::size_t patched = 0;           ///< clusters replaced by a patch
  std::size_t removed_triangles = 0; ///< surface triangles cut out
  std::size_t new_triangles = 0;     ///< triangles of the patches and their strips
  std::size_t voxels = 0;            ///< voxels of all grids built
  std::string first_failure;         ///< why the first cluster not patched was not (empty: none)
};

/// Replaces the surface around `pairs` (intersecting triangle pairs of `mesh`) by patches, in
/// place, where each patch checks as described above. `node_radius` is the radius of every
/// skeleton node (mesh.vertex_node indexes it; the local scale), `anchors` the points that
/// must stay inside. `origin` receives, per triangle of the result, the input triangle it
/// is, or the nearest cut-out triangle for a new one. Preconditions: `mesh` closed,
/// edge-manifold and consistently oriented; vertex_node filled.
VolumePatchStats volume_patch(Mesh& mesh, const std::vector<std::array<std::uint32_t, 2>>& pairs,
                              const Skeleton& skeleton, const VolumePatchOptions& options,
                              std::vector<std::uint32_t>& origin);

}  // namespace sm
