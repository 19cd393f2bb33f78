#pragma once
/// Contours stage: cross-section slices along every branch, split detection above forks and
/// the ordered boundary loop of the strands in each slice (Interactive Invigoration, Li et al.).
///
/// The result is a graph of loops that the meshing stage stitches:
///  - a `Tube` is a run of loops from its start (the root, or a split above a fork) up to its
///    end (a tip, or the next split); consecutive loops of a tube are stitched by strips;
///  - a `Junction` joins the last loop of a tube (the union of both bundles just below the
///    split) with the first loops of the two child tubes (branch fusion);
///  - the first loop of the root tube gets the base cap, the last loop of every tube ending at
///    a tip gets a tip cap.
///
/// Slicing: each edge is sliced at steps of `slice_step` x the local radius
/// measured along the edge; the leftover distance carries into the next edge(s), so slices
/// stay evenly spaced across nodes. A slice at distance d on the edge of node n (length L)
/// takes every strand of n at t = d / L: its cross-section coordinates interpolated between
/// the particle at parent(n) and at n, placed in the slice's frame on the edge axis (so
/// sections follow the skeleton's round cones; see contours.cpp for why not the 3D curves).
///
/// Split detection: above a fork F with children A (main) and B (lateral),
/// slices are taken on both child edges at the same distance above F. While the closest
/// points of the two bundles are nearer than `split_gap` x their neighbour distance, the slice is one loop
/// around the union; the first distance where they are farther apart is found by bisection
/// and becomes the split: from there on each bundle has its own tube. Bundles that do not
/// separate before the shorter child's segment ends (and min_fused_length x the fork's radius)
/// are split there (counted warning) once their points are loosely apart and each bundle's
/// surface clears the other subtree's round cones; branches whose cones still overlap stay
/// fused. Inside a fused section, a lateral of a fork in either
/// child's subtree (a whorl: forks a tiny step apart) whose bundle has come apart from the
/// rest splits off first, with its own junction (`split_nested_laterals`); the section then
/// resumes in a new tube without it, and that lateral's fork is walked as a plain node.
///
/// Boundary selection: the points of a slice are projected onto the slice
/// plane and the outer loop is found by the angular walk around the centroid (a Graham scan
/// that tolerates small concave turns), with orientation from exact-sign cross products
/// (never acos). The walk is verified (the loop turns monotonically around the centroid and
/// leaves no point outside). A slice that is not star-shaped around its centroid gets its
/// concave outline instead: the Delaunay triangulation of the points with boundary triangles
/// peeled off while their outer edge is longer than `fallback_max_edge` x the median
/// nearest-neighbour distance (a "chi-shape": one simple polygon around every point). It is
/// used when the walk fails, and when the walk bridges a long gap while the points form one
/// connected shape whose outline turns back around the centroid by more than a quarter turn
/// (a "C"). Bundles a gap apart and the shallow notches of a union stay bridged by the walk,
/// which is what branch fusion stitches best (see boundary.cpp). The fallback is counted
/// (warning "boundary_fallback").

#include <array>
#include <cstdint>
#include <span>
#include <vector>

#include "core/param_table.h"
#include "core/ids.h"
#include "core/math.h"
#include "core/progress.h"
#include "core/report.h"
#include "particles/particles.h"
#include "skeleton/skeleton.h"
#include "strands/strands.h"

namespace sm {

/// Factors on three contour parameters at one node (compute_contours' `local`).
struct LocalContourScale {
  double split_gap = 1.0;
  double fork_transition = 1.0;
  double slice_step = 1.0;
  friend bool operator==(const LocalContourScale&, const LocalContourScale&) = default;
};

struct ContourParams {
  /// Target length of a loop's edges, relative to the neighbour distance of the particles (the
  /// spacing of the strands on an outline): a loop keeps about perimeter / this of its boundary
  /// strands, evenly spaced along it, and slices follow each other at the height of an
  /// equilateral triangle on an edge of its round section (circumference / vertices), so
  /// triangles are close to isotropic: trunks get fine rings and close slices, thin twigs
  /// min_ring_vertices (or their strands, if fewer) and slices as max_slice_aspect allows.
  /// 0 = the legacy rings: every boundary strand, slices slice_step apart (needle triangles on
  /// thick branches and twigs; configs/legacy_rings.json, docs/quality.md).
  double ring_edge = 6.0;
  /// Fewest vertices a loop keeps where its boundary has more (a count; 6-gons' chords pass
  /// 13 % of the radius inside the round section, 7-gons' 10 %).
  std::uint32_t min_ring_vertices = 7;
  /// Scales the ring resolution and the slice spacing together (2 = edges half as long, twice
  /// min_ring_vertices, slices at least half of min_slice_step apart, twice max_slices_per_edge:
  /// about 4 times the triangles); with ring_edge > 0 only.
  double resolution = 1.0;
  /// Distance between consecutive slices along a branch, relative to the local radius (with
  /// ring_edge = 0; otherwise the slices follow the rings).
  double slice_step = 0.4;
  /// Most slices on one edge away from forks (a count; 0 = no limit): a long thin twig is a
  /// straight round cone between its nodes and needs no more; with ring_edge > 0,
  /// max_slice_aspect keeps its triangles from becoming needles.
  std::uint32_t max_slices_per_edge = 4;
  /// With ring_edge > 0, the slices of a loop whose edges are shorter than ring_edge asks (a
  /// thin twig held round by min_ring_vertices or its strands; mean edge under 0.7 ring_edge,
  /// fading out to 0.9) may be up to this many of its shortest edges apart where
  /// max_slices_per_edge wants them farther: triangles at most this elongated, at about a
  /// fifth of the isotropic twig's count (a ratio; 0 = isotropic everywhere).
  double max_slice_aspect = 4.5;
  /// Where a branch bends at a node, the straight strip between the loops on either side
  /// passes this far from the node at most (relative to its radius); farther, the node's own
  /// section is added as a loop (thin twigs sliced coarsely would otherwise leave their
  /// skeleton outside the surface), or in a fused section the split moves back to the node.
  double max_corner_cut = 0.25;
  /// Lower bound on the slice step, relative to the neighbour distance of the particles
  /// (ParticleField::neighbour_distance; keeps thin twigs from being sliced ever more finely).
  double min_slice_step = 1.0;
  /// Two bundles above a fork split where their closest points are farther apart than this,
  /// relative to the neighbour distance of the particles (1.0 = one empty particle slot).
  double split_gap = 1.5;
  /// At a fork whose thinner child is thinner than half a neighbour distance (the twigs of a
  /// tree sampled coarsely), the split gap is measured
  /// in this many of that child's radii instead, so the bundles split once they are apart on
  /// the twigs' scale rather than the particles' (each surface must still clear the other
  /// subtree's cones by half a split gap of neighbour distances); 0 = always the neighbour
  /// distance (docs/defaults.md: why 2).
  double thin_gap_radii = 2.0;
  /// Above a fork, each child's bundle goes from its place beside its sibling in the fork's
  /// section to its own round section within this distance, relative to the fork's radius
  /// (or the child edge's length, if shorter).
  double fork_transition = 1.5;
  /// Bundles that have not separated are split where the shorter child's segment ends (its
  /// next fork or tip), but no nearer the fork than this distance, relative to the fork's
  /// radius: a whorl (a chain of forks a tiny step apart) would otherwise split each lateral
  /// while it is still inside the trunk.
  double min_fused_length = 2.0;
  /// Inside the fused section above a fork, a lateral of a fork in either child's subtree (a
  /// whorl: forks a tiny step apart) whose bundle has come apart from the rest splits off
  /// there, with its own junction; otherwise it stays in the section's loops until the
  /// fork's own split, however far it has gone by then (a web across the whorl).
  bool split_nested_laterals = true;
  /// A thin tip (under 0.3 of its fork's radius) whose bundle has not come apart from its
  /// sibling's by the last slice below it splits off there when the tip lies outside the
  /// sibling's round cones, instead of ending inside the sibling's loops: absorbed, the twig
  /// would be missing from the mesh. false = only tips at least the skeleton's median radius
  /// (before 0.2; configs/separate.json).
  bool split_outside_tips = true;
  /// A tube's consecutive loops must not cross (one reaching behind the other's plane, where a
  /// branch bends within its own radius: zigzags, kinks of a fraction of a radius): the strip
  /// between them would turn inside out. Interior loops are left out of the tube until its
  /// consecutive loops are clear of each other, by at most `uncross_tolerance` x the radius.
  bool uncross_loops = true;
  /// How far a loop's point may lie behind its predecessor's plane (x loop radius).
  double uncross_tolerance = 0.02;
  /// Loops farther apart along the branch than this (x the larger loop radius) never count as
  /// crossing: that far, a crossing is a fork's tilted section, not a bend within the radius,
  /// and leaving out every loop between them would make one long strip.
  double uncross_reach = 8.0;
  /// Bisection steps refining the split position between two slices (a count).
  std::uint32_t split_bisection_steps = 8;
  /// Angular walk: concave turns sharper than this (degrees) remove the middle point; 0 gives
  /// the convex hull.
  double concave_turn_degrees = 12.0;
  /// Concave fallback for slices that are not star-shaped around their centroid: outline
  /// edges longer than this, relative to the median nearest-neighbour distance of the
  /// slice's points, are carved away (0 = fall back to the convex hull).
  double fallback_max_edge = 3.0;
};

/// The config key, accepted range, unit and help of each field of ContourParams, in header order
/// (core/param_table.h; the defaults are the initializers above).
const ParamTable<ContourParams>& param_table(std::type_identity<ContourParams>);

/// Where a loop comes from.
enum class LoopKind : std::uint8_t {
  plain,     ///< one bundle on one edge
  fused,     ///< the union of the two bundles above a fork, below the split
  split,     ///< the first loop of a child tube, at the split
  tip,       ///< the cross-section exactly at a tip node (last loop of its tube)
};

struct ContourStats {
  std::size_t loops = 0;
  std::size_t loop_vertices = 0;
  std::size_t evaluated_points = 0;     ///< strand evaluations (all slices and bisection)
  std::size_t fused_loops = 0;
  std::size_t forced_splits = 0;        ///< bundles that never separated within their edges
  std::size_t nested_splits = 0;        ///< laterals split off inside another fork's fused section
  std::size_t boundary_fallbacks = 0;   ///< slices not star-shaped around their centroid
  std::size_t uncrossed_loops = 0;      ///< interior loops left out of their tube: they crossed a neighbour
  Warnings warnings;
  Timings timings;
};

/// A run of loops stitched one to the next. `loops` are indices into ContourSet, bottom
/// (towards the root) to top.
struct Tube {
  std::vector<std::uint32_t> loops;
  std::uint32_t start_junction = UINT32_MAX;  ///< junction whose upper loop starts the tube, or none (root)
  std::uint32_t end_junction = UINT32_MAX;    ///< junction whose lower loop ends the tube, or none (tip)
  NodeId branch;                              ///< first node of the branch the tube belongs to
};

/// Branch fusion above one fork: `lower` is the last loop of the parent's tube (around both
/// bundles), `upper[0]` and `upper[1]` the first loops of the main and lateral child tubes.
/// For a lateral split off inside another fork's fused section (a nested split), `upper[0]`
/// starts the rest of that section and `lower_side` is 1 for the lateral's strands, 0 for all
/// others.
struct Junction {
  NodeId fork;
  std::uint32_t lower = 0;
  std::array<std::uint32_t, 2> upper{};
  std::uint32_t lower_tube = 0;
  std::array<std::uint32_t, 2> upper_tubes{};
  double split_distance = 0;  ///< distance above the fork where the bundles split (metres)
  bool forced = false;        ///< the bundles never separated; the split was forced
  /// #K (size of the lower loop): which bundle each lower-loop vertex's strand belongs to:
  /// 0 the main child's, 1 the lateral's, 2 neither (a strand that starts at or below the fork).
  std::vector<std::uint8_t> lower_side;
};

/// All loops (structure of arrays: #L loops, #V loop vertices in total).
struct ContourSet {
  std::vector<std::uint32_t> loop_begin;  ///< #L+1: loop l owns vertices [loop_begin[l], loop_begin[l+1])
  std::vector<dvec3> point;               ///< #V vertex positions (metres, world); CCW seen from the tip side
  std::vector<StrandId> strand;           ///< #V strand of each vertex
  std::vector<NodeId> loop_node;          ///< #L edge of the slice (the edge of node n, from parent(n) to n);
                                          ///< for fused loops, the main child's edge
  std::vector<double> loop_t;             ///< #L strand parameter on that edge
  std::vector<double> loop_distance;      ///< #L distance along the branch from its base (metres), for UVs
  std::vector<dvec3> loop_center;         ///< #L centre of the slice (on the skeleton)
  std::vector<Frame> loop_frame;          ///< #L slice frame; tangent points towards the tips
  std::vector<double> loop_radius;        ///< #L skeleton radius at the slice (metres)
  std::vector<LoopKind> loop_kind;        ///< #L
  std::vector<Tube> tubes;                ///< tube 0 starts at the root
  std::vector<Junction> junctions;
  ContourStats stats;

  [[nodiscard]] std::size_t loop_count() const { return loop_kind.size(); }
  [[nodiscard]] std::uint32_t loop_size(std::uint32_t l) const { return loop_begin[l + 1] - loop_begin[l]; }
};

/// Throws InvalidInputError naming the first parameter out of its range ("contours.slice_step
/// must be > 0, got 0"): a zero step or split gap would slice forever, a negative one means
/// nothing. compute_contours checks its parameters with it; the pipeline checks them before
/// its first stage, so a bad config file fails at once.
void validate_params(const ContourParams& params);

/// Slices every branch and selects the boundary loops.
/// Preconditions: `field` and `strands` were computed for `skeleton`.
ContourSet compute_contours(const Skeleton& skeleton, const ParticleField& field, const StrandSet& strands,
                            const ContourParams& params = {}, const ProgressFn& progress = {});
/// The same with factors on split_gap, fork_transition and slice_step per node of the
/// sanitized skeleton (#N, or empty for 1 everywhere): the repair stage slices the forks
/// around self-intersections again with them (repair/fork_retry.h). A fork's split test and
/// transition use its own factors; a slice on the edge of node n, n's slice step factor.
ContourSet compute_contours(const Skeleton& skeleton, const ParticleField& field, const StrandSet& strands,
                            const ContourParams& params, std::span<const LocalContourScale> local,
                            const ProgressFn& progress = {});

/// Boundary selection on its own (exposed for tests and the viewer): indices into `points` of
/// the outer loop, counter-clockwise, at least 3 when the points are not all collinear.
/// `fallback` (optional) is set to true when the angular walk had to be replaced by the
/// concave outline (`concave_hull` with `fallback_max_edge`; the convex hull when that is 0 or
/// the points are collinear).
std::vector<std::uint32_t> boundary_loop(const std::vector<dvec2>& points, double concave_turn_degrees,
                                         bool* fallback = nullptr, double fallback_max_edge = 3.0);
/// The same into `out` (its memory reused: the contour walk selects a loop per slice).
void boundary_loop(const std::vector<dvec2>& points, double concave_turn_degrees, std::vector<std::uint32_t>& out,
                   bool* fallback = nullptr, double fallback_max_edge = 3.0);

/// Concave outline of a point set ("chi-shape"): the Delaunay triangulation with boundary
/// triangles removed, longest outer edge first, while that edge is longer than
/// `relative_max_edge` x the median nearest-neighbour distance and the triangle's third point
/// is not on the outline yet. Indices into `points`, counter-clockwise from the lowest point,
/// one simple polygon with every point inside or on it; points collinear with their outline
/// neighbours are left out. Empty when the points are fewer than 3 or all collinear.
/// `connected` (optional) is set to whether the outline needs no edge longer than that limit
/// (false: the points form clusters farther apart, bridged by long outline edges).
std::vector<std::uint32_t> concave_hull(const std::vector<dvec2>& points, double relative_max_edge,
                                        bool* connected = nullptr);

}  // namespace sm
