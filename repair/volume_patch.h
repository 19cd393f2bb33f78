#pragma once
/// Volume patch: the last resort for crossings the self-union could not judge (a tube turned
/// inside out over a section, branches running inside each other, hubs of overlapping webs).
/// Around each cluster of such pairs the surface inside a box is cut out (triangles across
/// the box's faces are split there) and replaced by a surface drawn from a voxel grid: inside
/// the box the union of the input skeleton's round cones (the input is the truth; nodes the
/// sanitizing inserted are skipped), blended near the faces into the cut surface's own signed
/// distance so that the two meet. OpenVDB's volumeToMesh draws the level set; the patch is cut
/// along the same faces, its rims are zipped onto the holes vertex for vertex, and the patch's
/// vertices near the faces are put onto the cut surface.
///
/// A patch is kept only where it joins every hole, closes up (and, unless allowed, makes no
/// crossing) and keeps inside the anchors (skeleton nodes) that were. The cost of one grows
/// with its region (its voxels are bounded by `max_voxels`), not with the tree.

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "core/mesh.h"

namespace sm {
struct Skeleton;
}

namespace sm {

struct VolumePatchOptions {
  double voxels_per_radius = 4;         ///< voxel size: the thinnest local radius over this
  double reach = 2.5;                   ///< region: the pairs' box grown by this many local radii
  std::size_t max_voxels = 1'500'000;   ///< largest grid of one patch (coarser voxels beyond)
  std::size_t max_total_voxels = 40'000'000;  ///< all patches' grids together (the rest not patched)
  double min_voxels_per_radius = 2.5;   ///< a region whose thinnest (with min_twig_voxels: thickest) radius gets fewer is not patched
  double min_twig_voxels = 1.25;        ///< thinner branches drawn at this radius (voxels); 0: see above
  double grid = 0;                      ///< float grid of the positions (core/mesh.h), 0: none
  bool allow_crossings = false;         ///< keep a patch that crosses (the caller untangles it)
  std::vector<std::uint8_t> leave_out;  ///< per region (the step's order, as seam_crossings): not patched
  /// Skeleton nodes (indices) left outside the surface: each gets a region of its own, its box
  /// grown by `reach` + 1 of its radii (where the slicing could not separate a hub or a hairpin).
  /// Where given, only those regions are patched, with the pairs' regions that overlap them.
  std::vector<std::uint32_t> uncovered;
};

struct VolumePatchStats {
  std::size_t clusters = 0;          ///< clusters of pairs found
  std::size_t patched = 0;           ///< clusters replaced by a patch
  std::size_t removed_triangles = 0; ///< surface triangles cut out
  std::size_t new_triangles = 0;     ///< triangles of the patches and their strips
  std::size_t voxels = 0;            ///< voxels of all grids built
  std::map<std::string, std::size_t> failures;  ///< regions not patched, by why
  std::vector<std::size_t> seam_crossings;     ///< per region: crossings its patch's seams made (0: none kept)
  std::vector<std::array<glm::dvec3, 2>> regions;  ///< per region (same order): its box, lo and hi
  std::vector<std::uint8_t> made;              ///< per region (same order): its patch was made
  /// Where a patch was made: the result's new triangles (increasing), and every pair of the
  /// result with a triangle among them (sorted), so that the caller need not search again.
  std::vector<std::uint32_t> new_triangles_of_result;
  std::vector<std::array<std::uint32_t, 2>> pairs_of_new;
};

/// Replaces the surface around `pairs` (intersecting triangle pairs of `mesh`) and around the
/// `uncovered` nodes of the options by patches, in
/// place, where each patch checks as described above. `skeleton` gives the local scale (its
/// radii, indexed by mesh.vertex_node), the cones and the anchors (its nodes). `origin`
/// receives, per triangle of the result, the input triangle it is, or the nearest cut-out
/// triangle for a new one. Preconditions: `mesh` closed, edge-manifold and consistently
/// oriented; vertex_node filled.
VolumePatchStats volume_patch(Mesh& mesh, const std::vector<std::array<std::uint32_t, 2>>& pairs,
                              const Skeleton& skeleton, const VolumePatchOptions& options,
                              std::vector<std::uint32_t>& origin);

}  // namespace sm
