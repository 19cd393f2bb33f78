#pragma once
/// Procedural trees grown towards attraction points: the self-organizing tree of Pałubicki et
/// al. 2009 (as in Clasping Trees §3 and Tomasson 2022 §3; docs/growers.md lists the references)
/// and plain space colonization (Runions et al. 2007).
///
/// Attraction points are scattered in a crown volume (grow/volume.h). Every
/// iteration each bud perceives the points in its perception volume, each point going to the
/// nearest bud that perceives it; buds that perceived points get light Q = 1 (times the
/// shadow-propagation exposure when `shadow` is on, which also steers buds towards light). In self-organizing mode Q
/// flows down to the root and the resource αΣQ flows back up, split at every node by the Borchert–Honda rule with
/// apical control λ; a bud that receives v ≥ 1 grows a shoot of ⌊v⌋ internodes. In space-colonization mode every node
/// with points grows one internode per iteration. Points closer than the occupancy radius to a node are removed. After
/// growth, radii follow the pipe model d^n = d1^n + d2^n from a tip radius, and the skeleton is cleaned for the strand
/// mesher: consecutive internodes on thick branches are merged so edges are at least `min_edge_ratio` × radius long
/// where possible; a lateral crowded onto a thick axis (its fork too close to the next) is slid a few internodes up the
/// axis, or pruned when it is thin and cannot be slid.
///
/// Output guarantees (what build_skeleton() then finds, so it reports no repairs):
///  - a binary tree: every node has at most two children (a continuation and one lateral);
///  - node 0 is the root at the origin; parents come before children; z is up;
///  - every edge is longer than `internode_length` / 2 (no zero-length or short edges);
///  - radii are ≥ `tip_radius`, no child is thicker than its parent, and at every fork
///    r^n = r1^n + r2^n with n = `pipe_exponent` (to rounding);
///  - as grown, a lateral leaves its parent's direction at an angle in [min_branch_angle,
///    max_branch_angle], the two children of a fork are at least min_branch_angle apart, and a
///    branch bends by at most `max_turn_degrees` per internode (merged internodes average
///    these directions); no child points backwards.
///
/// Deterministic: the same parameters give the same skeleton bit for bit, for any thread
/// count. Every node draws its random numbers from its own stream, derived from the tree seed
/// and its place in the topology (not its creation order), so changing one parameter does not
/// reshuffle unrelated randomness (core/rng.h).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/progress.h"
#include "core/report.h"
#include "grow/volume.h"
#include "skeleton/skeleton.h"

namespace sm {

/// Which growth algorithm runs.
enum class GrowMode {
  self_organizing,     ///< buds with perception cones, Borchert–Honda resource, shoots (Pałubicki 2009)
  space_colonization,  ///< every node attracts points in a full sphere and grows one internode (Runions 2007)
};

/// All parameters of grow_tree(). Lengths are absolute metres (the tree grows from the origin,
/// z up); Clasping Trees §6.1 gives the ratios that work: perception radius 4–6 × and occupancy
/// radius ≈ 1.5–2 × the internode length, 20–80 attraction points per cubic unit.
struct GrowerParams {
  GrowMode mode = GrowMode::self_organizing;  ///< algorithm; default self_organizing
  std::uint64_t seed = 1;                     ///< random seed for points and per-branch streams; default 1
  CrownVolume crown{};                        ///< where attraction points are scattered; default one ellipsoid
  std::size_t attraction_points = 6000;       ///< number of attraction points (a count); default 6000

  // Buds and internodes.
  double internode_length = 0.15;          ///< length of one grown internode (metres); default 0.15
  double perception_radius = 0.8;          ///< reach of a bud's perception cone (metres); default 0.8
  double perception_angle_degrees = 90.0;  ///< full apex angle of the perception cone (degrees;
                                           ///< space colonization always uses 360); default 90
  double occupancy_radius = 0.3;           ///< points closer than this to a node are removed (metres); default 0.3
  double branching_angle_degrees = 45.0;   ///< angle of a lateral bud from its parent's direction (degrees); default 45
  double phyllotaxis_degrees =
      137.5;                   ///< azimuth step between successive lateral buds on a branch (degrees); default 137.5
  double inertia = 0.5;        ///< μ in [0, 1]: weight of a bud's own direction against the direction to
                               ///< its attraction points; default 0.5
  double tropism = 0.1;        ///< weight of the +z vector added to every new direction (relative to the
                               ///< unit direction; negative makes branches droop); default 0.1
  double trunk_tropism = 0.1;  ///< the same weight for the trunk axis (the root's chain of continuations),
                               ///< which replaces `tropism` there (large: a straight leader); default 0.1
  double direction_jitter_degrees =
      3.0;  ///< random deviation of every new internode (degrees, standard deviation); default 3

  // Resource distribution (self-organizing mode only).
  double apical_control = 0.55;  ///< λ in [0, 1] of the Borchert–Honda rule: > 0.5 favours the main axis; default 0.55
  double vigor = 2.0;            ///< α: resource at the root = α × total light (internodes per lit bud per
                                 ///< iteration, on average); default 2
  std::uint32_t max_shoot_internodes = 3;  ///< most internodes one bud grows in one iteration (a count); default 3

  // Shadow propagation (self-organizing mode only; Tomasson 2022 §3.3).
  bool shadow = false;  ///< when true, a bud's light is reduced by the shadow of the nodes above it; default false
  double shadow_voxel_size = 0.0;  ///< edge of a shadow voxel (metres; 0 = 2 × internode_length); default 0
  std::uint32_t shadow_depth = 6;  ///< q_max: voxel layers a node shades below itself (a count); default 6
  double shadow_a = 0.25;          ///< a: shadow a node adds to its own layer (same units as C); default 0.25
  double shadow_b = 3.0;           ///< b > 1: shadow falls off as a·b^(−q) with the layer q below; default 3
  double shadow_full = 4.0;        ///< C: shadow at which a bud gets no light (same units as a); default 4
  double shadow_steering = 0.5;    ///< weight of the direction to the least shaded neighbouring voxel, added to the
                                   ///< (unit) direction to the bud's points; default 0.5

  // Trunk and limits.
  dvec3 trunk_direction{0, 0, 1};      ///< initial growth direction of the root bud (unit vector); default +z
  double trunk_height = 1.5;           ///< straight trunk grown before buds seek the crown (metres); the trunk is
                                       ///< extended further until it perceives the crown; default 1.5
  std::uint32_t max_iterations = 300;  ///< growth iterations at most (a count); default 300
  std::size_t max_nodes = 200'000;     ///< growth stops once this many internodes exist (a count); default 200000

  // Radii (pipe model, Clasping Trees eq. 1, Tomasson 2022 §3.2).
  double tip_radius = 0.0015;  ///< radius of every branch tip (metres); default 0.0015
  double pipe_exponent = 2.3;  ///< n in d^n = d1^n + d2^n, between 1.8 and 2.8; default 2.3

  // Shape limits and cleanup for the strand mesher.
  double max_turn_degrees = 30.0;  ///< largest bend between consecutive internodes of a branch (degrees); default 30
  double min_branch_angle_degrees =
      15.0;  ///< smallest angle of a lateral from its parent's direction (degrees); default 15
  double max_branch_angle_degrees =
      70.0;                     ///< largest angle of a lateral from its parent's direction (degrees); default 70
  double min_edge_ratio = 2.0;  ///< internodes on one branch are merged until edges are at least this long
                                ///< (relative to the local radius); default 2
  double prune_ratio = 0.15;    ///< a lateral on a fork closer than min_edge_ratio × radius to the next fork that
                                ///< cannot be slid up its axis is pruned when thinner than this (relative to the
                                ///< parent radius); 0 = never; default 0.15
};

/// What grow_tree() did: counts, sizes, timings, warnings.
struct GrowStats {
  std::size_t iterations = 0;              ///< growth iterations run
  std::size_t attraction_points = 0;       ///< points scattered
  std::size_t points_reached = 0;          ///< points removed by the occupancy radius
  std::size_t grown_nodes = 0;             ///< nodes grown (before cleanup)
  std::size_t merged_nodes = 0;            ///< chain nodes merged away on thick branches
  std::size_t slid_laterals = 0;           ///< crowded laterals moved up their axis (subtree translated)
  std::size_t pruned_laterals = 0;         ///< crowded lateral subtrees removed
  std::size_t pruned_nodes = 0;            ///< nodes in those subtrees
  std::size_t nodes = 0;                   ///< nodes of the result
  std::size_t tips = 0;                    ///< tips of the result
  std::size_t forks = 0;                   ///< forks (nodes with two children) of the result
  std::size_t collisions_pruned = 0;       ///< small subtrees removed because they touched an unrelated branch
  std::size_t collision_pruned_nodes = 0;  ///< nodes in those subtrees
  std::size_t short_edges = 0;             ///< edges at a fork still shorter than min_edge_ratio × the larger radius
  std::size_t touching_edges = 0;          ///< pairs of edges of unrelated branches closer than their radii (left)
  double height = 0;                       ///< highest node above the root (metres)
  double trunk_radius = 0;                 ///< radius at the root (metres)
  Warnings warnings;                       ///< e.g. "no_growth" when no bud ever reached the crown
  Timings timings;                         ///< "scatter", "grow", "cleanup", "collisions"
};

struct GrowResult {
  RawSkeleton skeleton;                  ///< the grown tree (binary, clean), ids 0..N-1
  std::vector<dvec3> attraction_points;  ///< #P the scattered points (metres), for viewers and tests
  GrowStats stats;
};

/// Grows a tree. Throws InvalidInputError naming the parameter when a parameter is out of
/// range (see validate_grower_params) or the crown volume is empty. `progress` is called
/// from the calling thread with phases "scatter", "grow", "cleanup".
GrowResult grow_tree(const GrowerParams& params = {}, const ProgressFn& progress = {});

/// Checks every parameter's range; throws InvalidInputError("<field>: <rule>") on the first
/// violation. grow_tree() calls it; preset loaders call it to fail early.
void validate_grower_params(const GrowerParams& params);

}  // namespace sm
