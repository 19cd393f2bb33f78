#pragma once
/// The tree skeleton: the input of every later stage.
///
/// Two representations:
///  - `RawSkeleton` is what a file or a grower provides: any number of children per node,
///    arbitrary ids, possibly messy (zero-length edges, zero radii, thick children). It has
///    not been validated.
///  - `Skeleton` is the clean binary tree every later stage relies on, produced by
///    `build_skeleton()` (skeleton/build.h): validated, repaired, binarized and framed.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/ids.h"
#include "core/math.h"

namespace sm {

/// Which world axis points up in the input. Coordinates are kept as given; exporters convert
/// to the y-up convention of glTF.
enum class UpAxis { z, y };

/// A skeleton as read from a file or produced by a grower, before validation.
/// All arrays have the same length #N (one entry per node, in input order).
struct RawSkeleton {
  std::vector<std::int64_t> id;         ///< #N node ids as given (any distinct non-negative integers)
  std::vector<std::int64_t> parent_id;  ///< #N parent ids as given; -1 marks the root
  std::vector<dvec3> position;          ///< #N positions (metres, world frame of the input)
  std::vector<double> radius;           ///< #N radii (metres)
  /// #N or empty: radius of the edge to the node at its parent's end, 0 = the parent's radius
  /// (JSON "base_radius", written by strandmesh's own export: Skeleton::base_radius).
  std::vector<double> base_radius;
  std::vector<std::string> where;       ///< #N or empty: human-readable place of each node for
                                        ///< error messages ("line 12"); empty → "node id <id>"
  UpAxis up_axis = UpAxis::z;
  std::string source;  ///< informative description of the origin
  /// Written by strandmesh's skeleton stage (JSON key "sanitized": true): its geometric
  /// refinements (inner branches folded, steep laterals raised, branches separated) were
  /// applied already and are not applied again, so re-importing an export changes nothing.
  bool sanitized = false;
  /// Made by strandmesh's growers (JSON key "grown": true): their thin twig tips are by design,
  /// and the CLI lists the warnings about them only with --verbose.
  bool grown = false;

  [[nodiscard]] std::size_t size() const { return id.size(); }
  /// Appends a node; returns its index.
  std::size_t add(std::int64_t node_id, std::int64_t parent, dvec3 pos, double r);
  /// Human-readable place of node i for messages.
  [[nodiscard]] std::string place(std::size_t i) const;
};

/// A validated, binary, framed skeleton (structure of arrays, #N nodes).
///
/// Invariants (established by build_skeleton and checked by `validate_binary_skeleton`):
///  - node 0 is the root and `parent[i] < i` for every other node, so iterating indices
///    downwards visits children before parents (bottom-up) without recursion;
///  - every node has 0, 1 or 2 children; `children[i][0]` is the main continuation (the child
///    carrying more: the larger of its subtree's sum of tip radius² and its own radius², as
///    the fork was when binarized, before collar nodes widened laterals' bases; ties broken by
///    the lower index) and `children[i][1]` the lateral; a node with one child stores it in
///    slot 0;
///  - radii are finite and > 0, positions finite, edges have positive length;
///  - `frame[i]` is orthonormal, its tangent along the branch, obtained by parallel transport
///    from the root (see skeleton/frames.h).
struct Skeleton {
  std::vector<dvec3> position;                  ///< #N node positions (metres, input frame)
  std::vector<double> radius;                   ///< #N radii (metres), > 0
  std::vector<NodeId> parent;                   ///< #N parent, invalid for the root
  std::vector<std::array<NodeId, 2>> children;  ///< #N [main, lateral], invalid when absent
  std::vector<Frame> frame;                     ///< #N orthonormal cross-section frames
  std::vector<std::int64_t> source_id;          ///< #N id in the input; -1 for inserted nodes
  /// #N (or empty: all 0) radius of the edge to n at its parent's end where it is not the
  /// parent's radius, else 0. Set where sanitizing folded a branch's first nodes into the
  /// thicker branch they ran inside: the lateral then leaves at its own radius, as in the input.
  std::vector<double> base_radius;
  UpAxis up_axis = UpAxis::z;

  [[nodiscard]] std::size_t size() const { return position.size(); }
  [[nodiscard]] bool empty() const { return position.empty(); }
  [[nodiscard]] static NodeId root() { return NodeId(0u); }
  [[nodiscard]] int child_count(NodeId n) const {
    return int(children[n.idx()][0].valid()) + int(children[n.idx()][1].valid());
  }
  [[nodiscard]] bool is_tip(NodeId n) const { return !children[n.idx()][0].valid(); }
  [[nodiscard]] bool is_fork(NodeId n) const { return children[n.idx()][1].valid(); }
  /// Radius of the edge to n at its parent's end (metres): base_radius where set, else the
  /// parent's radius. Precondition: n is not the root.
  [[nodiscard]] double start_radius(NodeId n) const {
    const double b = n.idx() < base_radius.size() ? base_radius[n.idx()] : 0.0;
    return b > 0 ? b : radius[parent[n.idx()].idx()];
  }
  /// Length of the edge from n's parent to n (0 for the root).
  [[nodiscard]] double edge_length(NodeId n) const;
  /// Number of edges from the root to n.
  [[nodiscard]] std::vector<std::uint32_t> depths() const;
  /// #N branch id of every node: a branch is a maximal chain of main continuations; its id is
  /// the index of its first node (the root, or a lateral child). Used for `_BRANCH_ID`.
  [[nodiscard]] std::vector<std::uint32_t> branch_ids() const;
  /// The median node radius (the lower of the two middle ones for an even count; 0 when
  /// empty). Nodes at least this thick are "thick": the finished mesh must contain them
  /// (meshcheck/checks.h).
  [[nodiscard]] double median_radius() const;
  /// Human-readable name of node n for messages: "node 12 (input id 40)".
  [[nodiscard]] std::string describe(NodeId n) const;
  /// Appends a node with the given parent (invalid for the root) and returns its id. Slots:
  /// the first child added goes to slot 0. Frames are left default; call compute_frames().
  NodeId add_node(NodeId parent, dvec3 pos, double r, std::int64_t source = -1);
};

/// The skeleton as a raw skeleton (ids = node indices, parents first), e.g. to write it.
RawSkeleton raw_from_skeleton(const Skeleton& skeleton, const std::string& source = {});

}  // namespace sm
