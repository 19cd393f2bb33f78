#pragma once
/// What an engine needs from the tree, per vertex, to sway it in the wind and shade it: each
/// vertex's distance from the root along the tree and the skeleton's radius there, and per
/// branch its level, the point and direction where it leaves its parent, and a random phase.
/// docs/export.md says what an engine does with each.
///
/// A branch is a maximal chain of main continuations (Skeleton::branch_ids): the trunk is the
/// branch of the root, level 0; a lateral child starts a branch one level above its parent's.

#include <cstdint>
#include <vector>

#include <glm/glm.hpp>

#include "core/mesh.h"
#include "skeleton/skeleton.h"

namespace sm {

struct TreeAttributes {
  // Per welded vertex (#V):
  std::vector<float> root_distance;  ///< #V distance from the root along the skeleton to the vertex's place (metres)
  std::vector<float> thickness;      ///< #V skeleton radius at that place, interpolated along the edge (metres)
  std::vector<std::uint32_t> vertex_branch;  ///< #V branch of the vertex's skeleton node
  // Per branch, indexed by branch id (the index of the branch's first node; #N entries, only
  // those of branch starts meaningful):
  std::vector<std::uint32_t> level;     ///< 0 for the trunk, 1 for its laterals, ...
  std::vector<glm::dvec3> pivot;        ///< where the branch leaves its parent (the root for the trunk), mesh coordinates
  std::vector<glm::dvec3> direction;    ///< unit direction of the branch's first edge
  std::vector<float> phase;             ///< deterministic pseudo-random number in [0, 1) per branch
  // Ranges, for attributes packed into [0, 1]:
  float max_root_distance = 0;  ///< largest root_distance (metres)
  float max_thickness = 0;      ///< largest thickness (metres)
  std::uint32_t max_level = 0;  ///< largest level
};

/// The attributes of `mesh`, made from `skeleton` by the meshing stage. Each vertex is placed
/// at the nearest point of the skeleton edges at its node (Mesh::vertex_node: the edge to its
/// parent and those to its children). Throws InvalidInputError when the mesh has no
/// vertex_node (meshes read from files) or a node outside the skeleton.
TreeAttributes compute_tree_attributes(const Mesh& mesh, const Skeleton& skeleton);

}  // namespace sm
