#pragma once
/// Cylinder models (quantitative structure models: TreeQSM, SimpleForest, aRchi, rTwig) as
/// skeletons.
///
/// A QSM describes a tree as cylinders, each with a start and an end point, a radius and a
/// parent cylinder. The skeleton gets one node per cylinder end, and the start points are
/// shared where a child starts on its parent:
///  - a child that continues its parent (the parent's `extension`, or, without that column, a
///    child starting at the parent's end within 1 % of the radius) starts at the parent's end
///    node (TreeQSM leaves gaps of up to two radii there: a fitting artefact, not a shape);
///  - any other child starts on the parent's side: its start is projected onto the parent's
///    axis, the parent is split there by a node of the parent's radius, and the child's start
///    point (on the parent's surface for TreeQSM) becomes a node of the child's radius
///    attached to that axis node. A start on the axis itself (or at either end) is the axis
///    node.
/// Coordinates are kept as given (georeferenced models stay where they are).

#include <cstdint>
#include <string>
#include <vector>

#include "core/math.h"
#include "skeleton/skeleton.h"

namespace sm {

/// #C cylinders in file order; every array has one entry per cylinder (extension may be empty).
struct CylinderTable {
  std::vector<std::int64_t> id;         ///< #C cylinder ids as given (distinct)
  std::vector<std::int64_t> parent;     ///< #C parent ids; a parent that is no cylinder's id and
                                        ///< is < 0, or 0 when no id is 0, marks a root
  std::vector<std::int64_t> extension;  ///< #C or empty: id of the child continuing this
                                        ///< cylinder; one that is no cylinder's id means none
  std::vector<dvec3> start;             ///< #C start points (metres)
  std::vector<dvec3> end;               ///< #C end points (metres)
  std::vector<double> radius;           ///< #C radii (metres)
  std::vector<std::string> where;       ///< #C place in the file for messages ("line 12")
  std::string source;                   ///< the file, for messages

  [[nodiscard]] std::size_t size() const { return id.size(); }
};

/// The skeleton of a cylinder model (see the file comment). Node ids are 0..N-1 in the order
/// made (parents first); each node's `where` names the cylinder it comes from.
/// Throws InvalidInputError naming the place: duplicate ids, a parent id that is no cylinder's,
/// cylinders whose parents form a cycle, an empty table.
RawSkeleton cylinders_to_skeleton(const CylinderTable& table);

}  // namespace sm
