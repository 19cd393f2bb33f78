#pragma once
/// Skeleton stage entry point: validate, repair, binarize and frame a raw skeleton.
///
/// Validation comes first and rejects malformed input with an InvalidInputError naming the
/// node and the rule: no nodes, too many nodes, duplicate ids, negative ids, a missing parent,
/// several roots or none, cycles, non-finite coordinates or radii, negative radii, magnitudes
/// beyond SkeletonLimits.
///
/// Then each repair runs in this order, counted in the report (and as Warnings):
///  1. edges shorter than `merge_edge_ratio` × radius (or exactly zero) are merged into the
///     parent node (the child's children move to the parent);
///  2. radii below the floor are raised to it;
///  3. children thicker than their parent are clamped (or the parent raised; see policy);
///  4. optionally, edges longer than `max_edge_ratio` × radius are resampled;
///  5. nodes with more than two children become a chain of extra nodes a tiny step apart,
///     each with one lateral child (thickest laterals first, nearest the parent);
///  6. nodes are renumbered root-first (depth-first, main child first);
///  7. branches that run into each other away from their common fork are swung apart
///     (skeleton/separate.h), and the nodes are framed by parallel transport.

#include <cstddef>
#include <cstdint>

#include "core/param_table.h"
#include "core/report.h"
#include "skeleton/skeleton.h"

namespace sm {

/// Magnitudes a skeleton may have (checked before any repair; beyond them the input is
/// rejected naming the node and the rule). Meshes are written in float32 relative to the
/// tree's centre (meshio/export.h), whose 24-bit mantissa resolves about 1e-7 of the
/// tree's size: a tree more than a million times as large as its thinnest branch (after the
/// radius floor) cannot be meshed at the precision the contours need, and the costs of the
/// later stages grow with that ratio (docs/reliability.md).
/// Georeferenced trees (UTM or ECEF coordinates, millions of metres, with twigs of a
/// millimetre or less) are fine: the stages work in double precision, which resolves 1e-5 of
/// the thinnest radius up to 1e11 radii from the origin, and the float grid and the exported
/// offsets are relative to the tree.
struct SkeletonLimits {
  /// Largest |x|, |y|, |z| of any node plus its radius (metres): beyond any geographic frame.
  static constexpr double max_coordinate = 1e8;
  /// Largest |x|, |y|, |z| of any node plus its radius, over the thinnest radius.
  static constexpr double max_offset_ratio = 1e11;
  /// Largest extent (bounding box side, radii included) over the thinnest radius.
  static constexpr double max_extent_ratio = 1e6;
  /// Most children of one node. The contour stage's work at a hub grows with the square of
  /// its children (every split test there cuts the strands of all of them), and no mesh of
  /// thousands of twigs from one point follows its twigs (docs/reliability.md has the
  /// times). Measured trees have at most a few children per node.
  static constexpr std::size_t max_children = 10'000;
};

/// What to do with a child that is thicker than its parent.
enum class ThickChildPolicy {
  clamp_child,   ///< lower the child's radius to the parent's (default; local, predictable)
  raise_parent,  ///< raise the parent (and its ancestors as needed) to the child's radius
  keep,          ///< leave radii as they are (later stages cope; meshes may bulge)
};

struct SkeletonParams {
  /// Largest accepted node count; more is rejected as malformed input.
  std::size_t max_nodes = 20'000'000;
  /// Edges shorter than this fraction of the larger of their two radii are merged into the
  /// parent (relative to the local radius). Zero-length edges are always merged.
  double merge_edge_ratio = 0.05;
  /// Radius floor in metres; 0 = automatic: the smallest positive radius in the input, but
  /// at least 0.2% of the largest radius.
  double radius_floor = 0.0;
  /// A child may be at most this many times as thick as its parent before the policy applies.
  double max_child_ratio = 1.0;
  /// keep leaves radii as the input gives them (measured trees have children thicker than
  /// their parent at most nodes).
  ThickChildPolicy thick_child_policy = ThickChildPolicy::keep;
  /// Edges longer than this many times the local radius are split into equal parts;
  /// 0 disables resampling (default); otherwise at least 1.
  double max_edge_ratio = 0.0;
  /// Step between the extra nodes of a binarized whorl (an input node with 3 to
  /// max_chain_forks + 1 children), relative to the node's radius; hubs with more children
  /// and the cluster nodes grouping them keep their forks a merge tolerance apart (2 x
  /// merge_edge_ratio, also the least step). Large enough that at a whorl of near-equal
  /// children the lateral leaving first comes apart from the rest before the next fork.
  double binarize_step_ratio = 0.2;
  /// A node with more children than this (a hub: a QSM's or an L-system's fan of hundreds of
  /// twigs) first gets its laterals grouped by direction under at most this many cluster
  /// nodes, recursively, before binarizing (warning "clustered_children"). A chain of k binary
  /// forks carries every strand of the forks above it, so a chain of thousands of forks holds
  /// particles quadratic in k (docs/defaults.md); clusters keep chains at most this long.
  /// 0 disables (chains of any length).
  std::size_t max_chain_forks = 8;
  /// Merge a branch that runs inside its sibling's round cone into the sibling's edge (see
  /// build.cpp, merge_inner_branches); Sapling output needs it. Also removes tips lying
  /// wholly inside their parent's branch (drop_hidden_tips).
  bool merge_inner_branches = true;
  /// Where a lateral much thinner than its fork leaves, insert a node at this distance from
  /// the fork (relative to the fork's radius: 1 = on the parent's surface) so the lateral's
  /// round cone does not flare from the fork's full radius; 0 disables. Less than 1: a collar
  /// on the parent's surface sits in the crotch, where the mesh cuts the corner.
  double collar_ratio = 0.0;
  /// Only laterals thinner than this fraction of the fork's radius get a collar node.
  double collar_max_child_ratio = 0.7;
  /// ... and only those reaching at least this many of their own radii beyond the collar.
  /// Without a collar a short stub's round cone flares from the fork's full radius, wider
  /// than the stub, and the mesh (whose stub has the stub's girth) lies inside it.
  double collar_min_stub = 0.75;
  /// A lateral leaving its fork at more than this angle from the parent's direction
  /// (degrees; horizontal and drooping branches) gets a base node just outside the parent's
  /// surface, raised so its first stretch leaves at this angle; the branch then bends to its
  /// own direction. Strand bundles cannot leave a branch sideways or backwards without
  /// folding the surface at the fork. 0 (or 180) keeps every lateral as it is.
  double max_lateral_angle = 0.0;
  /// A child turning back from its node's incoming edge by more than this angle (degrees;
  /// digitised regrowth below a pruned top, branches doubling back) is re-attached to that
  /// edge at its projection, so it leaves sideways and the node above becomes a stub: no
  /// tube of the branch's radius can turn like that, and its strands would fold the surface.
  /// A repair (warning "hairpin"), part of the refinements; 0 (or 180) keeps them.
  double max_turn_back = 120.0;
  /// Tight bends: where a branch turns by t at a node with one child, its cross-sections
  /// need r tan(t/2) of straight edge on either side not to cross on the inner side of the
  /// bend (r the node's radius). A node needing more than this fraction of its shorter edge
  /// is removed, its child joined straight to its parent (warning "tight_bend"), but only
  /// where that chord passes within max_node_move x radius of it (any such node with
  /// `separate`): the input's zigzags stay where the file put them. 0 keeps every node.
  double tight_bend_ratio = 0.5;
  /// Opt-in shape edits that move the user's branches: swing apart branches whose round cones
  /// intersect away from their common fork (branch_clearance), re-attach hairpins
  /// (max_turn_back). Off: crossing branches stay where they are and the repair stage meshes
  /// their union (the input-faithful mode, `strandmesh mesh --keep-input`).
  bool separate = false;
  /// Largest distance any sanitizing step may move an input node, relative to its radius
  /// (merging a node into a sibling's or parent's edge that it lies inside); larger moves are
  /// made only by the opt-in `separate`.
  double max_node_move = 0.25;
  /// Gap the separation leaves between two such branches, relative to the sum of their radii.
  double branch_clearance = 0.15;
};

/// The config key, accepted range, unit and help of each field of SkeletonParams, in header order
/// (core/param_table.h; the defaults are the initializers above).
const ParamTable<SkeletonParams>& param_table(std::type_identity<SkeletonParams>);

/// The counted repairs of one build_skeleton() run, for `strandmesh info` and the viewer.
struct SkeletonReport {
  std::size_t input_nodes = 0;
  std::size_t output_nodes = 0;
  std::size_t merged_edges = 0;           ///< zero-length or too-short edges merged into parents
  std::size_t raised_radii = 0;           ///< radii raised to the floor
  std::size_t clamped_children = 0;       ///< thick children clamped (or parents raised)
  std::size_t resampled_edges = 0;        ///< long edges split
  std::size_t binarized_nodes = 0;        ///< nodes with more than two children
  std::size_t inserted_nodes = 0;         ///< extra nodes created by binarizing or resampling
  std::size_t clustered_nodes = 0;        ///< hubs whose laterals were grouped (max_chain_forks)
  std::size_t merged_inner = 0;           ///< nodes of branches running inside a sibling, merged into it
  std::size_t hairpins = 0;               ///< children turning back > 120 degrees, re-attached below their node
  std::size_t hidden_tips = 0;            ///< tips wholly inside their parent's branch, removed
  std::size_t tight_bends = 0;            ///< nodes of too tight bends removed (tight_bend_ratio)
  std::size_t collars = 0;                ///< collar nodes inserted at thin laterals (not a repair)
  std::size_t raised_laterals = 0;        ///< steep laterals given a raised base node (not a repair)
  std::size_t branch_collisions = 0;      ///< pairs of branches that ran into each other
  std::size_t unresolved_collisions = 0;  ///< of those, pairs still touching after separation
  double max_separation = 0;              ///< largest distance a node was moved to separate (metres)
  std::size_t dropped_nodes = 0;          ///< input nodes with no node of the result (merged or removed)
  double max_move = 0;                    ///< largest distance an input node kept was moved (metres)
  double max_move_radii = 0;              ///< the largest move relative to that node's radius
  double p95_move_radii = 0;              ///< 95th percentile of the moves relative to radius
  double radius_floor = 0;                ///< the floor used (metres)
  Warnings warnings;                      ///< one counted warning per kind of repair
  Timings timings;
};

struct SkeletonResult {
  Skeleton skeleton;
  SkeletonReport report;
};

/// Throws InvalidInputError naming the first parameter out of its range
/// ("skeleton.max_child_ratio must be > 0, got -1"). build_skeleton checks its parameters with
/// it; so does the config reader (parse_params_json), naming the file.
void validate_params(const SkeletonParams& params);

/// Validates and sanitizes `raw` into a binary framed skeleton.
/// Throws InvalidInputError (naming node and rule) on malformed input.
SkeletonResult build_skeleton(const RawSkeleton& raw, const SkeletonParams& params = {});

/// The skeleton exactly as the file gives it, for measuring a mesh against the input:
/// validated (throws like build_skeleton), radii below the radius floor raised to it, nothing
/// else changed. Nodes keep input order and any number of children: only `position`,
/// `radius`, `parent` and `source_id` are filled (not a stage input).
Skeleton input_skeleton(const RawSkeleton& raw, const SkeletonParams& params = {});

/// Checks the invariants documented on Skeleton; throws InternalError on the first breach.
/// Cheap (linear); used by tests and as a guard before later stages.
void validate_binary_skeleton(const Skeleton& skeleton);

}  // namespace sm
