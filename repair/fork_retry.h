#pragma once
/// Step 2 of the repair stage, the fork retry: where the mesh still has self-intersecting
/// triangle pairs or thick skeleton nodes outside it, the forks around them are sliced again
/// with other contour parameters, and each group of forks keeps the variant that does best there.
///
/// The pairs the fold repair cannot untangle sit at crotches (stubs, whorls, three-way hubs),
/// and whether a crotch folds, or swallows a stub's tip, depends on exactly where its slices
/// and split fall: changing the split gap, the fork transition or the slice step there moves
/// the pairs, and the best setting differs from crotch to crotch. So the retry meshes the tree
/// once per variant, the variant applied only at the forks around the problems
/// (compute_contours' `local`), and counts per group of forks:
///  - the forks of a pair are those on the tree paths between the nodes of its corners
///    (Crossing::nodes) within kReach of their radii of it; those of a thick node outside the
///    first mesh (radius at least the median, found as `strandmesh check` finds them) are the
///    forks among it and its ancestors within kReach of their radii; forks sharing a problem
///    form a group;
///  - the thick nodes near a group are tested in every run (winding numbers, counted as the
///    signed crossings of a ray with the triangles it can meet: core/mesh.h ClosedMeshInside).
/// A variant may leave neither more pairs nor more nodes outside at a group than the first run
/// did, nor lengthen the longest triangle edge near the group's forks (relative to their
/// radii) by more than half (a web spanning the crotch; see kWebGrowth in fork_retry.cpp);
/// among those, fewer nodes outside, then fewer pairs, is better. One more run combines
/// each group's best, and the best run overall (by the same rule, over the whole mesh) is
/// kept; ties keep the earlier run, so a clean mesh or a failed retry leaves the output as it
/// was. Deterministic: every run is, and the choices are made in a fixed order.
///
/// It costs up to 9 more runs of contours and meshing (and one combining the groups' choices),
/// one per thread at a time; docs/defaults.md has the figures and the variants not adopted.
///
/// It runs only where step 1 counted the pairs (Crossings::counted) and found some pairs or
/// thick nodes outside. On meshes of more than RepairParams::count_pairs_up_to triangles the
/// pairs are those the fold repair left near the forks, and the thick nodes outside are looked
/// for only where there are such pairs: each run of a retry on such a tree costs most of a
/// second, and the nodes it would find outside are near misses, which the next step covers.

#include <cstddef>
#include <string>

#include "contours/contours.h"
#include "core/progress.h"
#include "core/report.h"
#include "meshing/meshing.h"
#include "repair/junction_folds.h"
#include "skeleton/skeleton.h"

namespace sm {

struct RepairInputs;
struct RepairParams;

struct ForkRetryStats {
  std::size_t pairs_before = 0;  ///< self-intersecting pairs of the first mesh (0 if not counted)
  std::size_t pairs_after = 0;   ///< of the mesh kept
  std::size_t outside_before = 0;  ///< thick nodes near the groups outside the first mesh
  std::size_t outside_after = 0;   ///< of the mesh kept
  std::size_t groups = 0;        ///< groups of forks retried
  std::size_t runs = 0;          ///< extra runs of the contour and meshing stages
  std::size_t webs_refused = 0;  ///< better results at a group refused for spanning it with a web
  bool counted = false;          ///< the pairs were counted (see above)
  bool counted_everywhere = false;  ///< over the whole mesh (Crossings::everywhere)
};

/// One line of the retry's figures ("20 -> 2 self-intersecting pairs, ..."), for `strandmesh -v
/// mesh` and the viewer.
std::string to_text(const ForkRetryStats& stats);

/// A mesh after step 1, with what it was made from: what the retry compares and replaces.
struct ForkRetryState {
  ContourSet contours;
  MeshResult mesh;
  Crossings crossings;
  JunctionFoldStats folds;  ///< step 1's figures for this mesh
  Warnings warnings;        ///< step 1's warnings for this mesh
};

/// Retries the forks around the self-intersections and thick nodes outside of `state.mesh`
/// (contours, meshing and step 1 again per variant); `state` becomes the run kept.
ForkRetryStats retry_forks(ForkRetryState& state, const RepairInputs& inputs, const RepairParams& params,
                           const ProgressFn& progress = {});

/// Warns of the pairs of `crossings` (warning `self_intersections_left`, one per pair, naming
/// the crotch below each once; the viewer's problems layer shows them).
void warn_self_intersections_left(const Crossings& crossings, const Skeleton& skeleton, Warnings& warnings);

}  // namespace sm
