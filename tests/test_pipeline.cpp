// The whole pipeline on fixtures, grown trees and every sample skeleton.
//
// Every mesh must be one closed, consistently oriented 2-manifold of genus 0 with positive
// volume and no degenerate triangles: that holds by construction and is asserted everywhere.
// Self-intersections and fidelity to the skeleton are asserted strictly where the pipeline
// achieves them today (simple forks, the default grown tree, and on every sample skeleton no
// self-intersecting pair and every thick node inside); elsewhere (wide or chained forks of
// the fixtures, the samples' fidelity p95) they are held to regression bounds measured at the
// time of writing, so progress is kept and any regression fails.

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <set>
#include <tuple>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "core/errors.h"
#include "core/file_io.h"
#include "core/param_table.h"
#include "meshcheck/checks.h"
#include "pipeline/pipeline.h"
#include "grow/presets.h"
#include "grow/tree_grower.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"
#include "tests/separating.h"
#include "tests/sample_checks.h"

namespace sm {
namespace {

// The tests of this file were written for the shape edits of configs/separate.json (the defaults
// until the input was kept as given): they use them unless they say otherwise.
MeshCheckReport run_and_check(const RawSkeleton& raw, PipelineResult* out = nullptr,
                              const PipelineParams& params = test::separating()) {
  PipelineResult r = run_pipeline(raw, params);
  EXPECT_EQ(r.mesh.stats.bad_edges, 0u);
  MeshCheckParams cp;
  cp.skeleton = &r.skeleton.skeleton;
  MeshCheckReport rep = check_mesh(r.mesh.mesh, cp);
  if (out) *out = std::move(r);
  return rep;
}

/// The sample skeleton file with this name from tests/data/skeletons.
std::optional<std::filesystem::path> sample_named(const std::string& name) {
  for (const auto& f : test::sample_skeletons()) {
    if (f.filename() == name) return f;
  }
  return std::nullopt;
}

/// Closed, manifold, oriented, one component, genus 0, positive volume, no degenerate faces.
void expect_sound(const MeshCheckReport& rep) {
  EXPECT_TRUE(rep.closed) << rep.boundary_edges << " boundary edges";
  EXPECT_TRUE(rep.edge_manifold);
  EXPECT_TRUE(rep.vertex_manifold) << rep.nonmanifold_vertices << " non-manifold vertices";
  EXPECT_TRUE(rep.oriented);
  EXPECT_EQ(rep.components, 1u);
  ASSERT_TRUE(rep.genus.has_value());
  EXPECT_EQ(*rep.genus, 0);
  EXPECT_EQ(rep.degenerate_triangles, 0u);
  EXPECT_GT(rep.signed_volume, 0);
  EXPECT_EQ(rep.nonfinite_vertices, 0u);
}

/// The full promise: sound, no self-intersections, fidelity p95 <= 15% of the local radius,
/// every node at least as thick as the median inside the mesh.
void expect_perfect(const MeshCheckReport& rep) {
  expect_sound(rep);
  ASSERT_TRUE(rep.self_intersections_checked);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_LE(rep.fidelity_p95, 0.15);
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
}

/// Sound, with self-intersections and fidelity within measured regression bounds.
void expect_bounded(const MeshCheckReport& rep, std::size_t max_pairs, double max_p95, std::size_t max_outside) {
  expect_sound(rep);
  EXPECT_LE(rep.self_intersecting_pairs, max_pairs);
  EXPECT_LE(rep.fidelity_p95, max_p95);
  EXPECT_LE(rep.thick_nodes - rep.thick_nodes_inside, max_outside);
}

TEST(Pipeline, LateralLeavingFromInsideTheTrunkKeepsItsRadius) {
  // As Sapling writes laterals: each starts on the trunk's axis with a node of its own radius
  // (inside the trunk) and leaves from there. Sanitizing folds that node into the trunk; the
  // lateral's surface must still follow its own round cone (radius 0.05 at its base, not the
  // trunk's 0.15): within 0.15 of the local radius at the 95th percentile, measured against
  // the input with the defaults.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.2);
  raw.add(1, 0, dvec3(0, 0, 1), 0.17);
  raw.add(2, 1, dvec3(0, 0, 3), 0.12);
  raw.add(3, 2, dvec3(0, 0, 4), 0.08);
  raw.add(4, 1, dvec3(0, 0.002, 1.6), 0.05);   // the lateral's base node, on the trunk's axis
  raw.add(5, 4, dvec3(0.9, 0.002, 1.7), 0.04);  // leaves horizontally
  raw.add(6, 5, dvec3(1.7, 0.002, 2.0), 0.02);
  const PipelineResult r = run_pipeline(raw, PipelineParams{});
  EXPECT_GE(r.skeleton.report.merged_inner, 1u);
  const Skeleton input = input_skeleton(raw);
  MeshCheckParams cp{.skeleton = &input, .fidelity_worst = r.mesh.mesh.positions.size()};
  const MeshCheckReport rep = check_mesh(r.mesh.mesh, cp);
  expect_sound(rep);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_EQ(rep.nodes_inside, rep.nodes);
  // The vertices nearest the lateral's first edge (4 -> 5) beyond the crotch (they were 0.5-1.4
  // of the radius outside when the lateral started at the trunk's radius).
  std::vector<double> lateral;
  for (const FidelityVertex& v : rep.fidelity_worst) {
    if (v.node == 5 && v.t > 0.4) lateral.push_back(std::abs(v.deviation));
  }
  ASSERT_GE(lateral.size(), 8u);
  std::sort(lateral.begin(), lateral.end());
  EXPECT_LE(lateral[std::size_t(0.95 * double(lateral.size()))], 0.15) << lateral.size() << " vertices, max " << lateral.back();
  EXPECT_LE(rep.fidelity_p95, 0.15);
}

TEST(Pipeline, TightZigzagKeepsItsNodesAndStaysFaithful) {
  // A branch stepping sideways by two radii and back up (turns of 100 and 80 degrees, the
  // step 2 radii long): its cross-sections need more straight edge than the step has. With
  // the defaults no node is removed (the straightened branch would pass 1.9 radii from them)
  // and the surface follows the input's round cones: p95 within 0.15 of the radius, no
  // self-intersections, every node inside. (Removing node 3 put p95 at 0.63-0.79 and node 3
  // outside the mesh.)
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.05);
  raw.add(1, 0, dvec3(0, 0, 1.0), 0.04);
  raw.add(2, 1, dvec3(0, 0, 1.6), 0.03);
  raw.add(3, 2, dvec3(0.06, 0, 1.59), 0.03);
  raw.add(4, 3, dvec3(0.07, 0, 1.9), 0.025);
  raw.add(5, 4, dvec3(0.07, 0, 2.3), 0.02);
  const Skeleton input = input_skeleton(raw);
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    PipelineParams params;
    params.particles.seed = seed;
    const PipelineResult r = run_pipeline(raw, params);
    EXPECT_EQ(r.skeleton.report.tight_bends, 0u);
    EXPECT_EQ(r.skeleton.report.dropped_nodes, 0u);
    EXPECT_LE(r.skeleton.report.max_move_radii, 0.25);
    const MeshCheckReport rep = check_mesh(r.mesh.mesh, MeshCheckParams{.skeleton = &input});
    expect_sound(rep);
    EXPECT_EQ(rep.self_intersecting_pairs, 0u) << "seed " << seed;
    EXPECT_LE(rep.fidelity_p95, 0.15) << "seed " << seed;
    EXPECT_EQ(rep.nodes_inside, rep.nodes) << "seed " << seed;
  }
}

TEST(Pipeline, WhorlTwigTurningOutOfTheTrunkKeepsItsTip) {
  // A whorl (a node with three children, binarized into a chain of forks) whose thin twig
  // runs up inside the trunk for 11 of the trunk's radii (its axis 8 mm from the trunk's, the
  // trunk 10 mm thick) and then turns by 86 degrees out to its tip, 8 of its radii away (agraf
  // input nodes 661, 671, 672 with two siblings). Its bundle never comes apart from the trunk's
  // inside the fused section, which carried it past its tip: the tip segment had no tube and
  // node 3 lay 6.4 radii outside the mesh at every particle seed. It splits off before its
  // tip now, as a stub child of the fork itself does.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(-0.003, -0.062, 1.339), 0.01);
  raw.add(1, 0, dvec3(-0.025, -0.078, 1.45), 0.01);
  raw.add(2, 1, dvec3(-0.005, -0.076, 1.553), 0.0021);  // inside the trunk
  raw.add(3, 2, dvec3(0.011, -0.071, 1.551), 0.0021);   // the tip, outside it
  raw.add(4, 1, dvec3(-0.009, -0.08, 1.602), 0.0066);
  raw.add(5, 1, dvec3(-0.002, -0.066, 1.628), 0.00945);
  const Skeleton input = input_skeleton(raw);
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    PipelineParams params;
    params.particles.seed = seed;
    const PipelineResult r = run_pipeline(raw, params);
    const MeshCheckReport rep = check_mesh(r.mesh.mesh, MeshCheckParams{.skeleton = &input});
    expect_sound(rep);
    EXPECT_EQ(rep.self_intersecting_pairs, 0u) << "seed " << seed;
    EXPECT_EQ(rep.nodes_inside, rep.nodes) << "seed " << seed;
    // (0.10-0.20 with the twig's own tube; 0.10 without it, where its tip was missing.)
    EXPECT_LE(rep.fidelity_p95, 0.2) << "seed " << seed;
  }
}

TEST(Pipeline, SimpleForksArePerfect) {
  for (const auto& [name, raw] :
       std::vector<std::pair<std::string, RawSkeleton>>{{"straight_branch", test::straight_branch()},
                                                        {"y_fork", test::y_fork()},
                                                        {"y_fork_narrow", test::y_fork(10)},
                                                        {"zero_length_edges", test::zero_length_edges()},
                                                        {"thick_child", test::thick_child()}}) {
    SCOPED_TRACE(name);
    expect_perfect(run_and_check(raw));
  }
}

TEST(Pipeline, WideAndChainedForks) {
  // Known open: a T-shaped fork and binarized n-ary nodes still fold a few fusion triangles.
  SCOPED_TRACE("y_fork_wide");
  expect_bounded(run_and_check(test::y_fork(75)), 40, 0.16, 0);
  SCOPED_TRACE("trifurcation");
  expect_bounded(run_and_check(test::trifurcation()), 20, 0.15, 0);
  SCOPED_TRACE("six_children");
  expect_bounded(run_and_check(test::six_children()), 30, 0.15, 0);
}

TEST(Pipeline, LateralInsideAFusedSectionSplitsOffFirst) {
  // The small lateral comes apart from the fused section of the fork below it long before
  // that fork's bundles split: it gets its own junction there, and the section's loops stay
  // around the trunk and the narrow lateral.
  auto widest_fused_loop = [](const ContourSet& c) {
    double widest = 0;
    for (std::uint32_t l = 0; l < c.loop_count(); ++l) {
      if (c.loop_kind[l] != LoopKind::fused) continue;
      for (std::uint32_t v = c.loop_begin[l]; v < c.loop_begin[l + 1]; ++v)
        widest = std::max(widest, glm::length(c.point[v] - c.loop_center[l]));
    }
    return widest;
  };
  const RawSkeleton raw = test::lateral_inside_fused_section();
  PipelineResult r;
  const MeshCheckReport rep = run_and_check(raw, &r);
  expect_bounded(rep, 40, 0.15, 0);  // the narrow fork's forced split still folds a little
  EXPECT_EQ(r.contours.stats.nested_splits, 1u);
  ASSERT_EQ(r.contours.junctions.size(), 2u);
  EXPECT_LT(widest_fused_loop(r.contours), 0.3);  // fork radius 0.15, narrow lateral beside it
  // Without nested splits the lateral stays in the section until the fork's own split, far
  // out along its edge: the section's loops span a web out to it.
  PipelineParams kept_in = test::separating();
  kept_in.contours.split_nested_laterals = false;
  PipelineResult w;
  expect_sound(run_and_check(raw, &w, kept_in));
  EXPECT_EQ(w.contours.stats.nested_splits, 0u);
  EXPECT_GT(widest_fused_loop(w.contours), 0.45);
}

TEST(Pipeline, RandomWhorlTreesAreSound) {
  // Whorls of 1 to 4 laterals at random angles: binarized chains, nested splits, laterals
  // leaving inside another fork's fused section, stacked junctions merged into junctions of
  // three or more branches. Every mesh closed, manifold, genus 0, without unused vertices.
  std::size_t nested = 0, merged = 0;
  for (std::uint64_t seed = 1; seed <= 60; ++seed) {
    SCOPED_TRACE(seed);
    PipelineResult r = run_pipeline(test::random_whorl_tree(seed), test::separating());
    EXPECT_EQ(r.mesh.stats.bad_edges, 0u);
    MeshCheckParams cp;
    cp.skeleton = &r.skeleton.skeleton;
    cp.self_intersections = false;  // the whorls still fold (see the file comment)
    const MeshCheckReport rep = check_mesh(r.mesh.mesh, cp);
    EXPECT_TRUE(rep.closed && rep.edge_manifold && rep.vertex_manifold && rep.oriented);
    EXPECT_EQ(rep.components, 1u);
    ASSERT_TRUE(rep.genus.has_value());
    EXPECT_EQ(*rep.genus, 0);
    EXPECT_EQ(rep.degenerate_triangles, 0u);
    EXPECT_GT(rep.signed_volume, 0);
    EXPECT_EQ(rep.unreferenced_vertices, 0u);
    nested += r.contours.stats.nested_splits;
    merged += r.mesh.stats.merged_junctions;
  }
  EXPECT_GT(nested, 60u);   // the nested splits were exercised
  EXPECT_GT(merged, 100u);  // and the merged junctions
}

TEST(Pipeline, BentTwigsKeepTheirSkeletonInside) {
  // Two 1 mm zig-zag twigs (50 degree bends) leaving a fork, sliced coarsely (at most 4
  // slices per 6 cm edge) with slices falling just past each node: a straight strip across
  // a bend would pass outside the node; each such bend gets its own loop.
  RawSkeleton raw;
  raw.source = "zigzag_twigs";
  raw.add(0, -1, dvec3(0), 0.0012);
  raw.add(1, 0, dvec3(0, 0, 0.06), 0.0012);
  std::int64_t id = 2;
  for (const double side : {1.0, -1.0}) {
    dvec3 p(0, 0, 0.06);
    std::int64_t parent = 1;
    for (int i = 0; i < 10; ++i) {
      const double a = (side * 30.0 + (i % 2 == 0 ? 25.0 : -25.0)) * std::numbers::pi / 180.0;
      p += 0.06 * dvec3(std::sin(a), 0, std::cos(a));
      raw.add(id, parent, p, 0.001);
      parent = id++;
    }
  }
  // The separate mode's legacy rings (ring_edge 0) slice them as described, and so do the
  // default rings; without the bend loops the same twigs then leave nodes outside (the check
  // can fail).
  expect_perfect(run_and_check(raw));
  PipelineParams default_rings = test::separating();
  default_rings.contours = ContourParams{};
  expect_perfect(run_and_check(raw, nullptr, default_rings));
  PipelineParams straight_chords = test::separating();
  straight_chords.contours.max_corner_cut = 1e9;
  const MeshCheckReport rep = run_and_check(raw, nullptr, straight_chords);
  EXPECT_LT(rep.thick_nodes_inside, rep.thick_nodes);
}

TEST(Pipeline, DefaultGrownTreeIsPerfect) {
  expect_perfect(run_and_check(test::grown_tree(1)));
}

TEST(Pipeline, OtherGrownTrees) {
  SCOPED_TRACE("seed 2");
  expect_bounded(run_and_check(test::grown_tree(2)), 10, 0.15, 0);
  SCOPED_TRACE("seed 3");
  expect_bounded(run_and_check(test::grown_tree(3)), 30, 0.15, 1);
}

TEST(Pipeline, GrownTree72WithPreviewSettings) {
  // Bug 72: with the preview settings one strip of this tree fanned a whole loop round one
  // vertex of the next and the mesh had 4 edges not shared by exactly two triangles.
  const PipelineParams preview = load_params(std::filesystem::path(STRANDMESH_SOURCE_DIR) / "configs/preview.json");
  expect_sound(run_and_check(test::grown_tree(72), nullptr, preview));
}

TEST(Pipeline, FoldRepairUntanglesJunctions) {
  // Grown tree seed 3 folds at a few junctions when stitched as is; the edge flips of the
  // fold repair untangle most of them without moving a vertex: same vertices, same counts,
  // still closed, manifold and genus 0, and far fewer self-intersecting pairs (52 -> 6,
  // measured; the whole repair, with moves, collapses and refills, leaves none).
  PipelineParams off = test::separating(), flips_only = test::separating();
  off.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  off.repair.fold_rounds = 0;
  flips_only.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  flips_only.repair.fold_rounds = 0;
  off.repair.fork_retry = flips_only.repair.fork_retry = false;  // the stitched crotches as they are
  off.repair.junction_fold_rounds = 0;
  flips_only.repair.junction_fold_max_move = 0;
  flips_only.repair.junction_fold_collapses = flips_only.repair.junction_fold_refills = false;
  off.repair.sliver_angle = flips_only.repair.sliver_angle = 0;  // (the sliver step moves vertices)
  PipelineResult raw_result, repaired_result;
  const MeshCheckReport before = run_and_check(test::grown_tree(3), &raw_result, off);
  const MeshCheckReport after = run_and_check(test::grown_tree(3), &repaired_result, flips_only);
  EXPECT_GT(before.self_intersecting_pairs, 0u);
  EXPECT_LE(after.self_intersecting_pairs, before.self_intersecting_pairs / 3);
  EXPECT_EQ(run_and_check(test::grown_tree(3)).self_intersecting_pairs, 0u);
  EXPECT_GT(repaired_result.repair.junction_folds.flips, 0u);
  EXPECT_EQ(repaired_result.repair.junction_folds.moves, 0u);
  EXPECT_GT(repaired_result.repair.junction_folds.found, 0u);
  EXPECT_LE(repaired_result.repair.junction_folds.found, before.self_intersecting_pairs);
  EXPECT_EQ(raw_result.mesh.mesh.positions, repaired_result.mesh.mesh.positions);
  EXPECT_EQ(raw_result.mesh.mesh.triangle_count(), repaired_result.mesh.mesh.triangle_count());
  EXPECT_NE(raw_result.mesh.mesh.triangles, repaired_result.mesh.mesh.triangles);
  EXPECT_EQ(after.fidelity_p95, before.fidelity_p95);
  expect_sound(after);
}

TEST(Pipeline, FoldRepairMovesVerticesWhereFlipsDoNotHelp) {
  // A sample whose folds flips alone leave (boutdenoylum2: 116 pairs): bounded vertex moves
  // untangle more of them (49, measured), with every move within the limit and the surface
  // still sound and as faithful.
  const auto file = sample_named("mtg_boutdenoylum2.json");
  ASSERT_TRUE(file) << "sample skeleton missing from tests/data/skeletons";
  const RawSkeleton raw = read_skeleton(*file);
  PipelineParams flips_only = test::separating(), with_moves = test::separating();
  flips_only.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  flips_only.repair.fold_rounds = 0;
  with_moves.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  with_moves.repair.fold_rounds = 0;
  flips_only.repair.fork_retry = with_moves.repair.fork_retry = false;
  flips_only.repair.sliver_angle = with_moves.repair.sliver_angle = 0;  // (vertex for vertex)
  // (Sliced with crossing loops kept, as before contours.uncross_loops, which leaves no fold here.)
  flips_only.contours.uncross_loops = with_moves.contours.uncross_loops = false;
  flips_only.repair.junction_fold_max_move = 0;
  flips_only.repair.junction_fold_collapses = with_moves.repair.junction_fold_collapses = false;
  flips_only.repair.junction_fold_refills = with_moves.repair.junction_fold_refills = false;
  PipelineResult a, b;
  const MeshCheckReport flipped = run_and_check(raw, &a, flips_only);
  const MeshCheckReport moved = run_and_check(raw, &b, with_moves);
  EXPECT_GT(b.repair.junction_folds.moves, 0u);
  EXPECT_LT(moved.self_intersecting_pairs, flipped.self_intersecting_pairs * 3 / 4);
  EXPECT_LE(moved.fidelity_p95, flipped.fidelity_p95 + 0.01);  // +0.005 measured
  expect_sound(moved);
  ASSERT_EQ(a.mesh.mesh.positions.size(), b.mesh.mesh.positions.size());
  const Skeleton& sk = b.skeleton.skeleton;
  for (std::size_t v = 0; v < a.mesh.mesh.positions.size(); ++v) {
    const double r = sk.radius[b.mesh.mesh.vertex_node[v].idx()];
    // (Within the limit up to a step of the float grid the moved vertex is rounded to.)
    ASSERT_LE(glm::length(a.mesh.mesh.positions[v] - b.mesh.mesh.positions[v]), 0.25 * r * (1 + 1e-9) + b.mesh.grid)
        << v;
  }
}

TEST(Pipeline, FoldRepairCollapsesEdgesWhereMovesDoNotHelp) {
  // The pairs flips and moves leave (boutdenoylum2: 15, measured) mostly go with edge
  // collapses (4): each removes one vertex and two triangles, and the surface stays a closed
  // genus-0 2-manifold, as faithful.
  const auto file = sample_named("mtg_boutdenoylum2.json");
  ASSERT_TRUE(file) << "sample skeleton missing from tests/data/skeletons";
  const RawSkeleton raw = read_skeleton(*file);
  PipelineParams no_collapses = test::separating(), collapses_only = test::separating();
  no_collapses.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  no_collapses.repair.fold_rounds = 0;
  collapses_only.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  collapses_only.repair.fold_rounds = 0;
  no_collapses.repair.fork_retry = collapses_only.repair.fork_retry = false;
  no_collapses.repair.sliver_angle = collapses_only.repair.sliver_angle = 0;  // (its collapses alone)
  no_collapses.repair.junction_fold_collapses = false;
  no_collapses.repair.junction_fold_refills = collapses_only.repair.junction_fold_refills = false;
  PipelineResult a, b;
  const MeshCheckReport before = run_and_check(raw, &a, no_collapses);
  const MeshCheckReport after = run_and_check(raw, &b, collapses_only);
  const std::size_t collapses = b.repair.junction_folds.collapses;
  EXPECT_EQ(a.repair.junction_folds.collapses, 0u);
  EXPECT_GT(collapses, 0u);
  EXPECT_LT(after.self_intersecting_pairs, before.self_intersecting_pairs / 2);
  EXPECT_LE(after.fidelity_p95, before.fidelity_p95 + 0.005);
  EXPECT_GE(after.thick_nodes_inside, before.thick_nodes_inside);
  expect_sound(after);
  EXPECT_EQ(b.mesh.mesh.positions.size() + collapses, a.mesh.mesh.positions.size());
  EXPECT_EQ(b.mesh.mesh.triangles.size() + 2 * collapses, a.mesh.mesh.triangles.size());
  EXPECT_EQ(b.mesh.mesh.triangle_branch.size(), b.mesh.mesh.triangles.size());
}

TEST(Pipeline, FoldRepairRefillsDisksWhereNothingElseHelps) {
  // boutdenoylum2, without the fork retry (which would mend these crotches otherwise): of the
  // 44 pairs flips, moves and collapses leave (measured), most sit in folded disks around the
  // pruned stubs; triangulating each disk's boundary afresh leaves 10, with the surface a
  // closed genus-0 2-manifold, as faithful. No refill carries the surface across a skeleton
  // node (137 of 141 thick nodes inside either way, measured).
  const auto file = sample_named("mtg_boutdenoylum2.json");
  ASSERT_TRUE(file) << "sample skeleton missing from tests/data/skeletons";
  const RawSkeleton raw = read_skeleton(*file);
  PipelineParams no_refills = test::separating(), refills = test::separating();
  no_refills.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  no_refills.repair.fold_rounds = 0;
  refills.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  refills.repair.fold_rounds = 0;
  no_refills.repair.junction_fold_refills = false;
  no_refills.repair.fork_retry = refills.repair.fork_retry = false;
  PipelineResult a, b;
  const MeshCheckReport before = run_and_check(raw, &a, no_refills);
  const MeshCheckReport after = run_and_check(raw, &b, refills);
  EXPECT_EQ(a.repair.junction_folds.refills, 0u);
  EXPECT_GT(b.repair.junction_folds.refills, 0u);
  EXPECT_LT(after.self_intersecting_pairs, before.self_intersecting_pairs / 2);
  EXPECT_LE(after.fidelity_p95, before.fidelity_p95 + 0.005);
  EXPECT_GE(after.thick_nodes_inside + 1, before.thick_nodes_inside);
  expect_sound(after);
  EXPECT_LT(b.mesh.mesh.triangles.size(), a.mesh.mesh.triangles.size());
  EXPECT_EQ(b.mesh.mesh.triangle_branch.size(), b.mesh.mesh.triangles.size());
}

// Distance from p to the surface of the round cone of edge (parent(n), n); negative inside.
double cone_distance(const Skeleton& s, NodeId n, const dvec3& p) {
  const NodeId par = s.parent[n.idx()];
  const dvec3 a = s.position[par.idx()], b = s.position[n.idx()];
  const double l2 = glm::dot(b - a, b - a);
  const double t = l2 > 0 ? std::clamp(glm::dot(p - a, b - a) / l2, 0.0, 1.0) : 0.0;
  return glm::length(p - (a + t * (b - a))) - ((1 - t) * s.radius[par.idx()] + t * s.radius[n.idx()]);
}

TEST(Pipeline, ForcedSplitsWaitUntilTheBranchesClearEachOther) {
  // A lateral leaving at 11 degrees that forks 0.25 m above its fork, where its round cone
  // still overlaps its sibling's; a thin twig elsewhere sets a fine particle spacing, so the
  // thick bundles are "loosely apart" (half a spacing) there long before their cones are.
  // Split there, the two tubes would run through each other (2 crossing pairs, the first
  // loops inside the other child's cones): the split waits until each child's first loop
  // clears the other child's cones. (The lateral's main child runs beside the trunk to its
  // tip and is absorbed: its tip node may lie outside, hence expect_sound, not perfect.)
  RawSkeleton raw;
  raw.source = "near_parallel_siblings";
  const double a = 11.0 * std::numbers::pi / 180.0, seg = 0.25, rb = 0.045;
  const dvec3 fork(0, 0, 0.5), b = fork + seg * dvec3(std::sin(a), 0, std::cos(a));
  raw.add(0, -1, dvec3(0, 0, 0), 0.05);
  raw.add(1, 0, fork, 0.05);
  raw.add(2, 1, dvec3(0, 0, 1.0), 0.045);
  raw.add(3, 2, dvec3(0, 0, 1.6), 0.04);
  raw.add(4, 1, b, rb);
  raw.add(5, 4, b + dvec3(0.05, 0, 0.5), 0.7 * rb);
  raw.add(6, 4, b + dvec3(0.45, 0.1, 0.3), 0.5 * rb);
  raw.add(7, 2, dvec3(-0.3, 0, 1.2), 0.004);
  PipelineResult r;
  const MeshCheckReport rep = run_and_check(raw, &r);
  expect_sound(rep);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  const Skeleton& s = r.skeleton.skeleton;
  const ContourSet& c = r.contours;
  auto subtree = [&](NodeId x) {
    std::vector<NodeId> out{x};
    for (std::size_t k = 0; k < out.size(); ++k) {
      for (const NodeId ch : s.children[out[k].idx()]) {
        if (ch.valid()) out.push_back(ch);
      }
    }
    return out;
  };
  std::size_t forks = 0;
  for (const Junction& j : c.junctions) {
    ++forks;
    const auto& ch = s.children[j.fork.idx()];
    for (int side = 0; side < 2; ++side) {
      const std::uint32_t loop = j.upper[std::size_t(side)];
      for (const NodeId e : subtree(ch[std::size_t(1 - side)])) {
        for (std::uint32_t v = c.loop_begin[loop]; v < c.loop_begin[loop + 1]; ++v) {
          EXPECT_GT(cone_distance(s, e, c.point[v]), 0.0)
              << "junction at node " << j.fork.value << ": child " << side << "'s first loop inside edge " << e.value;
        }
      }
    }
  }
  EXPECT_GE(forks, 2u);
}

TEST(Pipeline, ShortStubsReachTheirTips) {
  // Pruned stubs 0.16-0.25 m long, nearly as thick as the trunk they leave (r 0.09 on r 0.1),
  // so their cones overlap the trunk's to the tip and their bundles mostly never separate.
  // Those split off at the last slice below their tip and get their own cap, so every tip
  // node lies inside the mesh. (Absorbed into the trunk's section instead, 5 of these 6 tips
  // were left outside, measured.) Measured: 5 of the 6 need the forced split (the 0.2 m stub
  // at 80 degrees parts from the trunk by itself).
  std::size_t forced = 0;
  for (const double length : {0.16, 0.2, 0.25}) {
    for (const double degrees : {60.0, 80.0}) {
      SCOPED_TRACE(testing::Message() << "stub " << length << " m at " << degrees << " degrees");
      RawSkeleton raw;
      raw.source = "short_thick_stub";
      const double a = degrees * std::numbers::pi / 180.0;
      raw.add(0, -1, dvec3(0, 0, 0), 0.1);
      raw.add(1, 0, dvec3(0, 0, 0.5), 0.1);
      raw.add(2, 1, dvec3(0, 0, 1.0), 0.09);
      raw.add(3, 2, dvec3(0, 0, 1.5), 0.08);
      raw.add(4, 3, dvec3(0, 0, 2.0), 0.05);
      raw.add(5, 1, dvec3(0, 0, 0.5) + length * dvec3(std::sin(a), 0, std::cos(a)), 0.09);
      PipelineResult r;
      const MeshCheckReport rep = run_and_check(raw, &r);
      expect_sound(rep);
      EXPECT_EQ(rep.self_intersecting_pairs, 0u);
      EXPECT_GE(rep.thick_nodes, 4u);
      EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
      forced += r.contours.stats.forced_splits > 0 ? 1 : 0;
    }
  }
  EXPECT_GE(forced, 4u);
}

/// A trunk of radius 0.075 with three pruned twigs (tip radius 0.002) whose tips end 2, 5 and 9
/// mm outside it, and a limb of 12 nodes of `limb_radius` (which sets the tree's median radius).
RawSkeleton twigs_beside_trunk(const std::string& source, double limb_radius) {
  RawSkeleton raw;
  raw.source = source;
  for (int i = 0; i < 5; ++i) raw.add(i, i - 1, dvec3(0, 0, 0.5 * i), 0.075);
  const double outside[] = {0.002, 0.005, 0.009};
  for (int k = 0; k < 3; ++k) {
    const double a = 2.0 * k;  // radians around the trunk
    const double h = 0.075 + outside[k];
    raw.add(10 + k, 1 + k, dvec3(h * std::cos(a), h * std::sin(a), 0.5 * (1 + k) + 0.08), 0.002);
  }
  for (int i = 0; i < 12; ++i) raw.add(20 + i, i == 0 ? 4 : 19 + i, dvec3(0.1 * (i + 1), 0, 2.0 + 0.03 * i), limb_radius);
  return raw;
}

TEST(Pipeline, ThinStubsJustOutsideTheTrunkReachTheirTips) {
  // Thin pruned twigs (tip r 0.002, most of the tree's nodes are as thin, so the tips are
  // thick nodes) whose tips end a few millimetres outside a trunk of radius 0.075, as on the
  // grown broadleaf at grow seeds 3 and 6. Their bundles never part from the trunk's, and
  // absorbed into its section the tips were left outside (the stub 2-9 mm out, measured: 2 of
  // 3 outside with the fork retry and the outer surface off). A thin tip outside the other
  // child's cones splits off below its tip like a thick stub (2 of the 3 here; the third
  // parts from the trunk by itself).
  const RawSkeleton raw = twigs_beside_trunk("thin_stubs_beside_trunk", 0.002);
  PipelineParams params = test::separating();
  params.repair.fork_retry = false;
  params.repair.outer_surface = false;
  PipelineResult r;
  const MeshCheckReport rep = run_and_check(raw, &r, params);
  expect_sound(rep);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_GE(rep.thick_nodes, 15u);
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
  EXPECT_GE(r.contours.stats.forced_splits, 2u);
}

TEST(Pipeline, ThinTwigsBesideTheTrunkAreNotAbsorbed) {
  // The same pruned twigs, now thinner than the tree's median radius (a thicker limb carries
  // most of the nodes), with the input as given: a thin tip outside the trunk's round cones
  // splits off below its tip instead of ending inside the trunk's loops, so every node of the
  // input is inside the mesh. Absorbed as before 0.2 (split_outside_tips off), tips are left
  // outside (the control: the check can fail).
  const RawSkeleton raw = twigs_beside_trunk("thin_twigs_beside_trunk", 0.01);
  PipelineResult r;
  const MeshCheckReport rep = run_and_check(raw, &r, PipelineParams{});
  expect_sound(rep);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  ASSERT_GT(r.skeleton.skeleton.median_radius(), 0.002);  // the twigs are thin
  EXPECT_EQ(rep.nodes_inside, rep.nodes);
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
  PipelineParams absorbed;
  absorbed.contours.split_outside_tips = false;
  const MeshCheckReport control = run_and_check(raw, nullptr, absorbed);
  EXPECT_LT(control.nodes_inside, control.nodes);
}

/// Moves `nodes` of a copy of r's skeleton 1.3 radii sideways (along the first one's frame
/// normal), so that they lie a little outside r's mesh, and covers them: the near misses'
/// figures, and the mesh check against the moved skeleton after.
std::pair<NearMissStats, MeshCheckReport> cover_moved_nodes(PipelineResult& r, const std::vector<NodeId>& nodes) {
  Skeleton s = r.skeleton.skeleton;
  const glm::dvec3 side = s.frame[nodes.front().idx()].normal;
  for (const NodeId n : nodes) s.position[n.idx()] += 1.3 * s.radius[n.idx()] * side;
  MeshCheckParams cp;
  cp.skeleton = &s;
  const MeshCheckReport before = check_mesh(r.mesh.mesh, cp);
  EXPECT_EQ(before.thick_nodes_inside + nodes.size(), before.thick_nodes);
  const NearMissStats st = cover_near_misses(r.mesh, s);
  return {st, check_mesh(r.mesh.mesh, cp)};
}

/// All `count` nodes moved out were covered, and the mesh after is sound, free of crossings,
/// with every thick node inside.
void expect_all_covered(const NearMissStats& st, const MeshCheckReport& after, std::size_t count) {
  EXPECT_EQ(st.outside_before, count);
  EXPECT_EQ(st.covered, count);
  EXPECT_EQ(st.outside_after, 0u);
  expect_sound(after);
  EXPECT_EQ(after.self_intersecting_pairs, 0u);
  EXPECT_EQ(after.thick_nodes_inside, after.thick_nodes);
}

TEST(Pipeline, NearMissesArePushedInside) {
  // A thick node of a plain branch moved sideways to 1.3 radii from its axis lies a little
  // outside the finished mesh: the surface nearest it is pushed over it, a few vertices moved,
  // and the mesh stays sound, with every thick node inside and no crossing.
  PipelineResult r = run_pipeline(test::y_fork(75), test::separating());
  const Skeleton& s = r.skeleton.skeleton;
  NodeId pick;
  for (std::size_t i = 1; i < s.size(); ++i) {
    const NodeId n(static_cast<std::uint32_t>(i));
    if (s.child_count(n) == 1 && s.parent[i].valid() && s.parent[s.parent[i].idx()].valid() &&
        (!pick.valid() || s.radius[i] > s.radius[pick.idx()]))
      pick = n;
  }
  ASSERT_TRUE(pick.valid());
  const std::vector<glm::dvec3> normals = r.mesh.mesh.normals;
  const auto [st, after] = cover_moved_nodes(r, {pick});
  expect_all_covered(st, after, 1);
  EXPECT_GE(st.moved_vertices, 3u);
  EXPECT_LE(st.moved_vertices, 20u);
  EXPECT_NE(r.mesh.mesh.normals, normals);  // recomputed where the surface moved
  EXPECT_EQ(r.mesh.mesh.normals, angle_weighted_normals(r.mesh.mesh));
}

TEST(Pipeline, NearMissesNextToEachOtherArePushedInRounds) {
  // Two neighbouring nodes of a straight branch (every node as thick), 6 cm apart on a 5 cm
  // radius, both moved 1.3 radii off its axis: their pushes share a neighbourhood, so the
  // second waits for a round of its own; both end inside and the mesh stays sound. (With one
  // round, one is covered.)
  RawSkeleton raw;
  raw.source = "straight_branch";
  for (int i = 0; i < 10; ++i) raw.add(i, i - 1, dvec3(0, 0, 0.06 * i), 0.05);
  PipelineResult r = run_pipeline(raw, test::separating());
  const NodeId a(4), b(5);
  ASSERT_EQ(r.skeleton.skeleton.children[a.idx()][0], b);
  const auto [st, after] = cover_moved_nodes(r, {a, b});
  expect_all_covered(st, after, 2);
}

TEST(Pipeline, DenseHubIsMeshedWithoutEndlessRepair) {
  // 300 twigs from one node on one chain of binary forks (no clusters) run through each other
  // (the separation cannot clear them): the mesh has far more self-intersecting pairs near
  // junctions than the fold repair takes on (FoldRepairOptions::max_pairs), so it is skipped
  // with a warning instead of running for hours. The surface is still one closed genus-0
  // manifold.
  const RawSkeleton raw = test::star(300);
  PipelineParams params = test::separating();
  params.skeleton.max_chain_forks = 0;
  const PipelineResult r = run_pipeline(raw, params);
  EXPECT_GT(r.repair.junction_folds.found, 20'000u);
  EXPECT_EQ(r.repair.junction_folds.flips + r.repair.junction_folds.refills + r.repair.junction_folds.collapses, 0u);
  EXPECT_EQ(r.warnings().count("fold_repair_skipped"), r.repair.junction_folds.found);
  expect_sound(check_mesh(r.mesh.mesh, {.self_intersections = false}));
}

TEST(Pipeline, HubOfThousandsOfTwigsIsMeshed) {
  // 2,000 twigs from one node. On one chain of 2,000 binary forks every fork carries the
  // strands of all the forks above it (about 10 M particles, and the contour stage ran for
  // many minutes); clustered (SkeletonParams::max_chain_forks) the particles stay near-linear
  // in the twigs, and the tangle of twigs is meshed closed and in one part. Twigs of the
  // tangle cross each other, and their union may have handles: genus is not asserted.
  const RawSkeleton raw = test::star(2000);
  // (The fork retry runs the contour and meshing stages 12 more times on this tangle: 2.5 ->
  // 25 s, 89 -> 16 pairs, 1,312 -> 995 thick nodes outside. Not what this test is about.)
  PipelineParams params = test::separating();
  params.repair.fork_retry = false;
  const PipelineResult r = run_pipeline(raw, params);
  EXPECT_GT(r.skeleton.report.clustered_nodes, 0u);
  EXPECT_EQ(r.warnings().count("dense_branches"), 1u);
  EXPECT_LT(r.particles.position.size(), 400'000u);
  const MeshCheckReport rep = check_mesh(r.mesh.mesh, {.self_intersections = false});
  EXPECT_TRUE(rep.closed && rep.edge_manifold && rep.vertex_manifold && rep.oriented);
  EXPECT_EQ(rep.components, 1u);
  EXPECT_GT(rep.signed_volume, 0);
}

TEST(Pipeline, FoldRepairVariantsKeepTheBestRun) {
  // boutdenoylum2 at particle seed 3: the fold repair leaves 9 self-intersecting pairs; run
  // again from the stitched mesh with vertex moves also towards the branches' axes, none.
  // (Seed 2 until the vertices were put on the float grid, which changed which pairs the
  // repair meets: now 0 there, and 2 -> 0 / 9 -> 0 / 7 -> 5 / 13 -> 0 at seeds 1 / 3 / 4 / 5.)
  const auto file = sample_named("mtg_boutdenoylum2.json");
  ASSERT_TRUE(file) << "sample skeleton missing from tests/data/skeletons";
  const RawSkeleton raw = read_skeleton(*file);
  PipelineParams params = test::separating();
  params.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  params.repair.fold_rounds = 0;
  params.particles.seed = 3;
  params.repair.fork_retry = false;
  params.contours.uncross_loops = false;  // (as before it: uncrossed loops leave no fold here)
  auto pairs = [&](bool variants) {
    params.repair.junction_fold_variants = variants;
    const PipelineResult r = run_pipeline(raw, params);
    return check_mesh(r.mesh.mesh).self_intersecting_pairs;
  };
  const std::size_t one = pairs(false), best = pairs(true);
  EXPECT_GT(one, 0u);
  EXPECT_LT(best, one);
}

TEST(Pipeline, LocalContourFactorsChangeOnlyTheirFork) {
  // compute_contours' `local` factors (the fork retry's tool): a wider split gap at one fork moves that
  // fork's split up; the junctions of forks outside its subtree stay where they were.
  PipelineResult r;
  run_and_check(test::grown_tree(1), &r);
  const Skeleton& s = r.skeleton.skeleton;
  // The last plain split (junctions are in walk order: its fork's subtree is small).
  const auto plain = std::find_if(r.contours.junctions.rbegin(), r.contours.junctions.rend(), [&](const Junction& j) {
    return !j.forced && s.children[j.fork.idx()][1].valid();
  });
  ASSERT_NE(plain, r.contours.junctions.rend());
  const NodeId fork = plain->fork;
  const double split = plain->split_distance;
  std::vector<LocalContourScale> local(s.size());
  local[fork.idx()].split_gap = 2.0;
  const ContourSet c = compute_contours(s, r.particles, r.strands, test::separating().contours, local);
  auto in_subtree = [&](NodeId n) {
    for (; n.valid(); n = s.parent[n.idx()]) {
      if (n == fork) return true;
    }
    return false;
  };
  std::size_t same = 0;
  bool found = false;
  for (const Junction& j : c.junctions) {
    if (j.fork == fork) {
      found = true;
      EXPECT_GT(j.split_distance, split);
      continue;
    }
    if (in_subtree(j.fork)) continue;
    const auto before = std::find_if(r.contours.junctions.begin(), r.contours.junctions.end(),
                                     [&](const Junction& k) { return k.fork == j.fork; });
    ASSERT_NE(before, r.contours.junctions.end());
    EXPECT_EQ(before->split_distance, j.split_distance);
    ++same;
  }
  EXPECT_TRUE(found);
  EXPECT_GT(same, 10u);
  // All factors 1: the same contours as without any.
  local.assign(s.size(), LocalContourScale{});
  EXPECT_EQ(compute_contours(s, r.particles, r.strands, test::separating().contours, local).point, r.contours.point);
}

TEST(Pipeline, TwigForksSplitOnTheTwigsScale) {
  // The conifer preset: twigs of 1.5 mm against a neighbour distance of 5.7 mm. With the
  // split gap measured in twig radii at their forks (ContourParams::thin_gap_radii, on by
  // default) the twigs' bundles split nearer their forks than with the neighbour distance as
  // the unit (a smaller web in each crotch), and the mesh is still perfect.
  const GrowPreset preset =
      load_grow_preset(std::filesystem::path(STRANDMESH_SOURCE_DIR) / "configs" / "grow" / "conifer.json");
  PipelineResult r;
  expect_perfect(run_and_check(grow_tree(preset.params).skeleton, &r));
  const Skeleton& s = r.skeleton.skeleton;
  const double nd = r.particles.neighbour_distance;
  ContourParams off = test::separating().contours;
  ASSERT_GT(off.thin_gap_radii, 0.0);
  off.thin_gap_radii = 0;
  const ContourSet c = compute_contours(s, r.particles, r.strands, off);
  std::map<std::uint32_t, double> split_off;
  for (const Junction& j : c.junctions) split_off[j.fork.idx()] = j.split_distance;
  std::size_t nearer = 0, farther = 0, twig_forks = 0;
  double sum_on = 0, sum_off = 0;
  for (const Junction& j : r.contours.junctions) {
    const auto& ch = s.children[j.fork.idx()];
    if (!ch[1].valid() || 2.0 * std::min(s.radius[ch[0].idx()], s.radius[ch[1].idx()]) >= nd) continue;
    const auto it = split_off.find(j.fork.idx());
    if (it == split_off.end()) continue;
    ++twig_forks;
    sum_on += j.split_distance;
    sum_off += it->second;
    nearer += j.split_distance < it->second ? 1 : 0;
    farther += j.split_distance > it->second ? 1 : 0;
  }
  EXPECT_GT(twig_forks, 100u);
  EXPECT_GT(nearer, 10 * farther);
  EXPECT_LT(sum_on, 0.9 * sum_off);
}

TEST(Pipeline, ForkRetryKeepsEachCrotchsBestVariant) {
  // boutdenoylum2 at particle seed 1: stitched and repaired, 2 self-intersecting pairs are
  // left at one crotch and 4 thick nodes outside; sliced again around them with other split
  // gaps, transitions and slice steps, no pair and three nodes fewer outside (measured); the
  // last node outside gets the surface pushed over it (near misses; before those, a sphere
  // joined to the mesh by the outer surface), so all are inside.
  // The retry's and the outer surface's figures match the checks of both meshes and the
  // surface stays sound and as faithful.
  const auto file = sample_named("mtg_boutdenoylum2.json");
  ASSERT_TRUE(file) << "sample skeleton missing from tests/data/skeletons";
  const RawSkeleton raw = read_skeleton(*file);
  PipelineParams off = test::separating(), on = test::separating();
  off.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  off.repair.fold_rounds = 0;
  on.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  on.repair.fold_rounds = 0;
  off.repair.fork_retry = false;
  off.repair.cover_near_misses = false;
  off.repair.sliver_angle = on.repair.sliver_angle = 0;  // (its edits may remove a pair the retry counted)
  // (Sliced with crossing loops kept, as before contours.uncross_loops, which leaves no pair here.)
  off.contours.uncross_loops = on.contours.uncross_loops = false;
  PipelineResult a, b;
  const MeshCheckReport before = run_and_check(raw, &a, off);
  const MeshCheckReport after = run_and_check(raw, &b, on);
  EXPECT_GT(before.self_intersecting_pairs, 0u);
  EXPECT_LT(after.self_intersecting_pairs, before.self_intersecting_pairs);
  EXPECT_EQ(a.repair.fork_retry.runs, 0u);
  EXPECT_TRUE(b.repair.fork_retry.counted);
  EXPECT_EQ(b.repair.fork_retry.pairs_before, before.self_intersecting_pairs);
  EXPECT_EQ(b.repair.fork_retry.pairs_after, after.self_intersecting_pairs);
  EXPECT_GE(b.repair.fork_retry.groups, 1u);
  EXPECT_GE(b.repair.fork_retry.runs, 1u);
  EXPECT_LE(after.fidelity_p95, before.fidelity_p95 + 0.005);
  EXPECT_GT(after.thick_nodes_inside, before.thick_nodes_inside);
  EXPECT_GE(b.repair.near_misses.covered + b.repair.outer_surface.blobs, 1u);
  EXPECT_EQ(after.thick_nodes_inside, after.thick_nodes);
  if (b.repair.outer_surface.tried) {
    EXPECT_EQ(b.repair.outer_surface.nodes_inside_after, after.thick_nodes_inside);
  }
  EXPECT_EQ(b.repair.fork_retry.outside_before - b.repair.fork_retry.outside_after + b.repair.near_misses.covered +
                (b.repair.outer_surface.nodes_inside_after - b.repair.outer_surface.nodes_inside_before),
            after.thick_nodes_inside - before.thick_nodes_inside);
  expect_sound(after);
  EXPECT_NE(a.contours.point, b.contours.point);  // sliced otherwise somewhere
}

TEST(Pipeline, ForkRetryDoesNotSpanACrotchWithAWeb) {
  // agraf at particle seed 4: a slicing that untangles the whorl of forks near
  // (-0.1673, 0.2151, 1.7209) (forks 931-935, 9.6 mm) spans it with a web of large flat
  // triangles, edges 8.1 fork radii long against 3.3 in the first mesh (measured). The retry
  // refuses it (a group's longest edge may grow by half at most) and keeps another: no pair
  // left, every thick node inside, and no edge near that fork longer than 1.5 x 3.3. (Until
  // the fused sections got a last loop a fine step below their splits, agraf at seed 2 had
  // such a web at the fork near (-0.256, -0.323, 1.148); its first mesh now needs none.)
  const auto file = sample_named("mtg_agraf.json");
  ASSERT_TRUE(file) << "sample skeleton missing from tests/data/skeletons";
  PipelineParams p = test::separating();
  p.repair.self_union = false;  // the earlier repairs alone, not the repair stage
  p.repair.fold_rounds = 0;
  p.particles.seed = 4;
  PipelineResult r;
  const MeshCheckReport rep = run_and_check(read_skeleton(*file), &r, p);
  expect_sound(rep);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
  EXPECT_GE(r.repair.fork_retry.webs_refused, 1u);
  const Skeleton& s = r.skeleton.skeleton;
  const glm::dvec3 at(-0.1673, 0.2151, 1.7209);
  NodeId fork;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s.is_fork(NodeId(i)) &&
        (!fork.valid() || glm::length(s.position[i] - at) < glm::length(s.position[fork.idx()] - at)))
      fork = NodeId(i);
  }
  ASSERT_TRUE(fork.valid());
  ASSERT_LT(glm::length(s.position[fork.idx()] - at), 0.002);
  const double radius = s.radius[fork.idx()];
  double longest = 0;
  for (const auto& t : r.mesh.mesh.triangles) {
    const auto& m = r.mesh.mesh.positions;
    if (glm::length((m[t[0]] + m[t[1]] + m[t[2]]) / 3.0 - s.position[fork.idx()]) > 6 * radius) continue;
    for (int k = 0; k < 3; ++k) longest = std::max(longest, glm::length(m[t[(k + 1) % 3]] - m[t[k]]));
  }
  EXPECT_LT(longest / radius, 1.5 * 3.3);
}

TEST(Pipeline, Samples) {
  const auto files = test::sample_skeletons();
  ASSERT_FALSE(files.empty()) << "tests/data/skeletons is empty";
  // Self-intersecting pairs and thick nodes outside: none (particle seeds 1-3 all measured
  // so). Fidelity p95: a regression bound measured with some margin; see the file comment.
  const std::map<std::string, std::tuple<std::size_t, double, std::size_t>> bounds{
      {"mtg_agraf.json", {0, 0.12, 0}},
      {"mtg_boutdenoylum2.json", {0, 0.115, 0}},
      {"qsm_simpleforest_rtwig.json", {0, 0.065, 0}},
      {"sapling_callistemon.json", {0, 0.075, 0}},
      {"sapling_quaking_aspen.json", {0, 0.05, 0}},
      {"sapling_small_pine.json", {0, 0.09, 0}}};
  for (const auto& f : files) {
    const std::string name = f.filename().string();
    SCOPED_TRACE(name);
    const MeshCheckReport rep = run_and_check(read_skeleton(f));
    if (const auto it = bounds.find(name); it != bounds.end()) {
      const auto& [pairs, p95, outside] = it->second;
      expect_bounded(rep, pairs, p95, outside);
    } else {
      expect_sound(rep);  // a sample added later: at least a sound surface
    }
  }
}

TEST(Pipeline, SamplesWithTheDefaultsAgainstTheInput) {
  // The default pipeline (the faithful one: Pipeline.Samples above runs the separate mode) on
  // every sample, checked as `strandmesh check --skeleton FILE` checks: against the skeleton as
  // the file gives it. One closed, oriented 2-manifold in one piece; pairs, fidelity p95 and
  // thick nodes outside within regression bounds: the figures of 2026-11-29, pairs and nodes
  // exact, p95 with a margin. (Issue 30's goal is no pair and every thick node inside.)
  const auto files = test::sample_skeletons();
  ASSERT_FALSE(files.empty()) << "tests/data/skeletons is empty";
  const std::map<std::string, std::tuple<std::size_t, double, std::size_t>> bounds{
      {"mtg_agraf.json", {0, 0.105, 3}},
      {"mtg_boutdenoylum2.json", {0, 0.115, 0}},
      {"qsm_simpleforest_rtwig.json", {0, 0.095, 0}},
      {"sapling_callistemon.json", {23, 0.075, 2}},
      {"sapling_quaking_aspen.json", {0, 0.055, 0}},
      {"sapling_small_pine.json", {65, 0.115, 8}}};
  for (const auto& f : files) {
    const std::string name = f.filename().string();
    SCOPED_TRACE(name);
    const MeshCheckReport rep = test::mesh_and_check_against_input(read_skeleton(f));
    test::expect_one_sound_piece(rep);
    EXPECT_GT(rep.signed_volume, 0);
    if (const auto it = bounds.find(name); it != bounds.end()) {  // (else a sample added later)
      const auto& [pairs, p95, outside] = it->second;
      test::expect_within(rep, pairs, p95, outside);
    }
  }
}

TEST(Pipeline, GoldenStatistics) {
  // Fixed seed, fixed parameters: counts within 2% (they move only when an algorithm does).
  PipelineResult r;
  run_and_check(test::grown_tree(1), &r);
  EXPECT_EQ(r.skeleton.skeleton.size(), 471u);
  EXPECT_NEAR(double(r.particles.strand_count()), 2766.0, 2766.0 * 0.02);
  EXPECT_NEAR(double(r.mesh.mesh.vertex_count()), 18612.0, 18612.0 * 0.02);  // (the separate mode's legacy rings)
  EXPECT_NEAR(double(r.mesh.mesh.triangle_count()), 37220.0, 37220.0 * 0.02);
  EXPECT_EQ(r.mesh.mesh.triangle_count(), 2 * r.mesh.mesh.vertex_count() - 4);  // genus 0, all triangles
}

TEST(Pipeline, DeterministicAcrossRuns) {
  PipelineResult a, b;
  run_and_check(test::grown_tree(4), &a);
  run_and_check(test::grown_tree(4), &b);
  ASSERT_EQ(a.mesh.mesh.positions.size(), b.mesh.mesh.positions.size());
  EXPECT_EQ(a.mesh.mesh.positions, b.mesh.mesh.positions);
  EXPECT_EQ(a.mesh.mesh.triangles, b.mesh.mesh.triangles);
}

TEST(Pipeline, IdenticalForOneAndTwoThreads) {
  // Every stage runs in parallel (particles per subtree, contours per tube, normals per
  // vertex, ...) and must not depend on the schedule: a sample with whorls and forced splits
  // meshed on 1 and on 2 threads, bit for bit.
  const auto file = sample_named("sapling_small_pine.json");
  ASSERT_TRUE(file) << "sample skeleton missing from tests/data/skeletons";
  const RawSkeleton raw = read_skeleton(*file);
  auto run_with = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    return run_pipeline(raw, test::separating());
  };
  const PipelineResult one = run_with(1), two = run_with(2);
  EXPECT_EQ(one.contours.point, two.contours.point);
  EXPECT_EQ(one.contours.loop_begin, two.contours.loop_begin);
  ASSERT_EQ(one.contours.junctions.size(), two.contours.junctions.size());
  for (std::size_t j = 0; j < one.contours.junctions.size(); ++j) {
    EXPECT_EQ(one.contours.junctions[j].lower, two.contours.junctions[j].lower);
    EXPECT_EQ(one.contours.junctions[j].upper, two.contours.junctions[j].upper);
  }
  EXPECT_EQ(one.mesh.mesh.positions, two.mesh.mesh.positions);
  EXPECT_EQ(one.mesh.mesh.triangles, two.mesh.mesh.triangles);
  EXPECT_EQ(one.mesh.mesh.normals, two.mesh.mesh.normals);
  EXPECT_EQ(one.mesh.mesh.corner_uvs, two.mesh.mesh.corner_uvs);
  EXPECT_EQ(one.contours.stats.warnings.to_string(), two.contours.stats.warnings.to_string());
}

TEST(Pipeline, SingleNodeSkeletonIsRejected) {
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.1);
  EXPECT_THROW(run_pipeline(raw, test::separating()), InvalidInputError);
}

TEST(Pipeline, ExportSectionFromTheTable) {
  // The config's `export` section is read, written and checked through its table like the
  // stages' sections: names for the choices, a list for the attributes, unit names for the
  // scale; an unknown key, a wrong value or one out of range names the file and the key.
  const PipelineParams p = parse_params_json(
      R"({"export": {"up_axis": "z", "pivot": "center", "scale": "cm", "attributes": "normal", "compress": "meshopt",
          "lods": 3}})",
      "c.json");
  EXPECT_EQ(p.output.file_up_axis, UpAxis::z);
  EXPECT_EQ(p.output.pivot, Pivot::center);
  EXPECT_EQ(p.output.scale, 100.0);
  EXPECT_TRUE(p.output.normals);
  EXPECT_FALSE(p.output.uvs);
  EXPECT_FALSE(p.output.branch_ids);
  EXPECT_EQ(p.output.compress, Compression::meshopt);
  EXPECT_EQ(p.output.lods, 3u);
  const std::string text = params_to_json(p);
  EXPECT_EQ(params_to_json(parse_params_json(text, "x")), text);  // round trip
  const nlohmann::json j = nlohmann::json::parse(text)["export"];
  EXPECT_EQ(j["scale"], 100.0);
  EXPECT_EQ(j["attributes"], "normal");
  EXPECT_EQ(j["pivot"], "center");
  EXPECT_EQ(nlohmann::json::parse(params_to_json({}))["export"]["up_axis"], "auto");
  for (const auto& [config, message] : std::vector<std::pair<std::string, std::string>>{
           {R"({"export": {"pivott": "root"}})", "c.json: export: unknown key \"pivott\" (did you mean \"pivot\"?)"},
           {R"({"export": {"scale": -1}})", "c.json: export.scale must be > 0, got -1"},
           {R"({"export": {"scale": "km"}})", "c.json: export.scale: scale must be a positive number"},
           {R"({"export": {"up_axis": 3}})", "c.json: export.up_axis: must be a string: y, z, auto, not 3"},
           {R"({"export": {"lods": 9}})", "c.json: export.lods must be in [1, 8], got 9"},
           {R"({"export": {"attributes": "nrmal"}})", "did you mean \"normal\""}}) {
    try {
      parse_params_json(config, "c.json");
      ADD_FAILURE() << config;
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
}

TEST(Pipeline, KeysTheRepairStageTookStillLoad) {
  // Configs from before the repair stage took its switches over from the meshing section load:
  // each old key is read as its new one; where the new key is given too, it wins.
  const PipelineParams p = parse_params_json(
      R"({"meshing": {"fork_retry": true, "fold_repair_rounds": 3, "count_pairs_up_to": 10, "tip_dome": 0.5},
          "repair": {"count_pairs_up_to": 20}})",
      "old.json");
  ASSERT_FALSE(RepairParams{}.fork_retry);
  EXPECT_TRUE(p.repair.fork_retry);
  EXPECT_EQ(p.repair.junction_fold_rounds, 3u);
  EXPECT_EQ(p.repair.count_pairs_up_to, 20u);
  EXPECT_EQ(p.meshing.tip_dome, 0.5);
  // An old key's value is checked as the new key's.
  try {
    parse_params_json(R"({"meshing": {"fork_retry": 1}})", "old.json");
    ADD_FAILURE() << "no error";
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("old.json: repair.fork_retry: must be true or false"), std::string::npos)
        << e.what();
  }
  // Every moved key names a key of its new section and a key its old section no longer has.
  const auto& t = param_table_of<RepairParams>();
  ASSERT_FALSE(t.moved.empty());
  for (const ParamMoved& m : t.moved) {
    EXPECT_TRUE(std::any_of(t.fields.begin(), t.fields.end(), [&](const auto& f) { return std::string(f.key) == m.now; }))
        << m.now;
    const auto& mesh = param_table_of<MeshParams>().fields;
    EXPECT_FALSE(std::any_of(mesh.begin(), mesh.end(), [&](const auto& f) { return std::string(f.key) == m.key; }))
        << m.key;
  }
}

TEST(Pipeline, ShippedConfigsLoad) {
  std::size_t n = 0;
  for (const auto& e : std::filesystem::directory_iterator(std::filesystem::path(STRANDMESH_SOURCE_DIR) / "configs")) {
    if (e.path().extension() != ".json") continue;
    SCOPED_TRACE(e.path().string());
    EXPECT_NO_THROW(load_params(e.path()));
    // Written with today's keys (a key that moved would load with a warning).
    const nlohmann::json j = nlohmann::json::parse(read_file(e.path()));
    for (const ParamMoved& m : param_table_of<RepairParams>().moved) {
      EXPECT_FALSE(j.contains(m.section) && j[m.section].contains(m.key)) << m.section << "." << m.key;
    }
    ++n;
  }
  EXPECT_GE(n, 3u);  // default, preview, high_detail
  // default.json spells out exactly the built-in defaults.
  EXPECT_EQ(params_to_json(load_params(std::filesystem::path(STRANDMESH_SOURCE_DIR) / "configs/default.json")),
            params_to_json(PipelineParams{}));
}

TEST(Pipeline, ParamsOutOfRangeAreRejectedNamingTheKey) {
  // A zero slice step or split gap sliced forever, a huge bisection count, a dome of 1e9 radii
  // or a resampling of 1e-9 radii as good as (every config key tried at 0, -1, 1e-9 and 1e9 on
  // the default tree: these ran past 30 s, a few others were internal errors); every such
  // value fails when the config is read (naming the file and the key) and again when a stage
  // is called with it, before any work.
  for (const auto& [config, key] : std::vector<std::pair<std::string, std::string>>{
           {R"({"contours": {"slice_step": 0, "min_slice_step": 0}})", "contours.slice_step must be > 0"},
           {R"({"contours": {"split_gap": -1}})", "contours.split_gap must be > 0"},
           {R"({"contours": {"split_bisection_steps": 100000000}})", "contours.split_bisection_steps"},
           {R"({"contours": {"concave_turn_degrees": 180}})", "contours.concave_turn_degrees"},
           {R"({"contours": {"thin_gap_radii": -2}})", "contours.thin_gap_radii must be >= 0"},
           {R"({"meshing": {"tip_dome": -5}})", "meshing.tip_dome must be in [0, 10]"},
           {R"({"meshing": {"tip_dome": 1e9}})", "meshing.tip_dome must be in [0, 10]"},
           {R"({"skeleton": {"max_child_ratio": -1}})", "skeleton.max_child_ratio must be > 0"},
           {R"({"skeleton": {"max_lateral_angle": 270}})", "skeleton.max_lateral_angle must be in [0, 180]"},
           {R"({"skeleton": {"max_edge_ratio": 1e-9}})", "skeleton.max_edge_ratio must be 0 (off) or at least 1"},
           {R"({"meshing": {"uv_repeat_u": 0}})", "meshing.uv_repeat_u must be > 0"}}) {
    SCOPED_TRACE(config);
    try {
      parse_params_json(config, "cfg.json");
      ADD_FAILURE() << "accepted";
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find("cfg.json: " + key), std::string::npos) << e.what();
    }
  }
  PipelineParams p = test::separating();
  p.contours.slice_step = 0;
  EXPECT_THROW(run_pipeline(test::y_fork(), p), InvalidInputError);
  p = {};
  p.meshing.uv_repeat_u = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(run_pipeline(test::y_fork(), p), InvalidInputError);
  p = {};
  p.skeleton.collar_min_stub = -1;
  EXPECT_THROW(run_pipeline(test::y_fork(), p), InvalidInputError);
}

TEST(Pipeline, SmallChildRatiosKeepTheRadiusFloor) {
  // max_child_ratio 0.1 clamps each generation to a tenth of its parent: without the radius
  // floor the twigs of the default tree reached 1e-17 m and their collars zero-length edges
  // (an internal error). And collar_min_stub 0 put a collar on its child. Now both mesh.
  for (const auto& set :
       std::vector<std::function<void(PipelineParams&)>>{[](PipelineParams& q) { q.skeleton.max_child_ratio = 0.1; },
                                                         [](PipelineParams& q) { q.skeleton.collar_min_stub = 0; }}) {
    PipelineParams p = test::separating();
    set(p);
    PipelineResult r;
    expect_sound(run_and_check(test::grown_tree(1), &r, p));
    const Skeleton& s = r.skeleton.skeleton;
    for (std::size_t i = 0; i < s.size(); ++i) EXPECT_GE(s.radius[i], r.skeleton.report.radius_floor * (1 - 1e-12));
  }
}

TEST(Pipeline, ParamsJsonRoundTripAndStrictKeys) {
  PipelineParams p = test::separating();
  p.particles.seed = 77;
  p.contours.slice_step = 0.3;
  p.skeleton.thick_child_policy = ThickChildPolicy::keep;
  const PipelineParams q = parse_params_json(params_to_json(p), "x.json");
  EXPECT_EQ(q.particles.seed, 77u);
  EXPECT_EQ(q.contours.slice_step, 0.3);
  EXPECT_EQ(q.skeleton.thick_child_policy, ThickChildPolicy::keep);
  // The largest value of a 64-bit field is read exactly (its limit was once converted from a
  // double, 2^64, out of uint64_t's range: undefined, found by the sanitizer build), one more is
  // an error.
  EXPECT_EQ(parse_params_json(R"({"particles": {"seed": 18446744073709551615}})", "x.json").particles.seed,
            std::numeric_limits<std::uint64_t>::max());
  EXPECT_EQ(parse_params_json(R"({"repair": {"count_pairs_up_to": 18446744073709551615}})", "x.json")
                .repair.count_pairs_up_to,
            std::numeric_limits<std::size_t>::max());
  EXPECT_THROW(parse_params_json(R"({"particles": {"seed": 18446744073709551616}})", "x.json"), InvalidInputError);
  EXPECT_THROW(parse_params_json(R"({"particles": {"sed": 3}})", "x.json"), InvalidInputError);
  EXPECT_THROW(parse_params_json(R"({"particle": {}})", "x.json"), InvalidInputError);
  EXPECT_THROW(parse_params_json(R"({"contours": {"slice_step": "big"}})", "x.json"), InvalidInputError);
  try {
    parse_params_json(R"({"particles": {"sed": 3}})", "cfg.json");
    FAIL();
  } catch (const InvalidInputError& e) {
    EXPECT_NE(std::string(e.what()).find("cfg.json: particles: unknown key \"sed\" (did you mean \"seed\"?)"),
              std::string::npos)
        << e.what();
  }
  for (const auto& [config, message] : std::vector<std::pair<std::string, std::string>>{
           {R"({"particles": {"slice_step": 1}})", "unknown key \"slice_step\" (it belongs in section \"contours\")"},
           {R"({"contour": {}})", "unknown section \"contour\" (did you mean \"contours\"?)"},
           {R"({"strands": {"zzz": 1}})", "unknown key \"zzz\" (known keys: alpha)"},
           {R"({"strands": {"alpha": 2}})", "strands.alpha must be in [0, 1], got 2"},
           {R"({"particles": {"damping": 1}})", "particles.damping must be in [0, 1), got 1"},
           {R"({"particles": {"min_particles": 4294967296}})", "particles.min_particles: must be a non-negative integer"},
           {R"({"skeleton": {"thick_child_policy": "thin"}})", "\"clamp_child\", \"raise_parent\" or \"keep\""}}) {
    SCOPED_TRACE(config);
    try {
      parse_params_json(config, "cfg.json");
      ADD_FAILURE() << "accepted";
    } catch (const InvalidInputError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  }
}

// The number of fields of an aggregate (counted by how many initializers it accepts).
struct AnyInit {
  template <class T>
  operator T() const;  // NOLINT(google-explicit-constructor)
};
template <class T, class... A>
constexpr std::size_t field_count() {
  if constexpr (requires { T{A{}..., AnyInit{}}; }) {
    return field_count<T, A..., AnyInit>();
  } else {
    return sizeof...(A);
  }
}

template <class P>
void expect_sound_table(std::size_t fields_not_in_table = 0) {
  const ParamTable<P>& t = param_table_of<P>();
  SCOPED_TRACE(t.section);
  // A field added to a Params struct needs its row in the stage's table (<stage>/param_table.cpp).
  EXPECT_EQ(t.fields.size() + fields_not_in_table, field_count<P>());
  std::set<std::string> keys;
  for (std::size_t i = 0; i < t.fields.size(); ++i) {
    const ParamSpec<P>& s = t.fields[i];
    EXPECT_TRUE(keys.insert(s.key).second) << "duplicate key " << s.key;
    EXPECT_FALSE(std::string(s.help).empty()) << s.key;
    const ParamKind kind = param_kind(s);
    if (kind == ParamKind::real || kind == ParamKind::integer) {
      EXPECT_NE(s.range.rule(), "any") << s.key;
    }
    // Two keys never name one member (a copy-paste slip would read one field twice).
    for (std::size_t j = 0; j < i; ++j) {
      if (kind != ParamKind::choice && param_kind(t.fields[j]) != ParamKind::choice) {
        EXPECT_FALSE(s.field == t.fields[j].field) << s.key << " and " << t.fields[j].key;
      }
    }
    // Each field is reached through its member: setting it changes that field only (a text
    // field reads back what it writes).
    P p{};
    if (kind == ParamKind::text) {
      const auto& text = std::get<ParamText<P>>(s.field);
      const std::string was = text.get(p);
      text.set(p, was);
      EXPECT_EQ(text.get(p), was) << s.key;
      EXPECT_FALSE(std::string(text.accepted).empty()) << s.key;
      continue;
    }
    const double old = param_value(p, s);
    set_param_value(p, s, old == 0 ? 1 : 0);
    EXPECT_NE(param_value(p, s), old) << s.key;
  }
  EXPECT_NO_THROW(check_params(P{}));  // the defaults are accepted
}

TEST(Pipeline, ParamTablesCoverEveryField) {
  expect_sound_table<SkeletonParams>();
  expect_sound_table<ParticleParams>();
  expect_sound_table<StrandParams>();
  expect_sound_table<ContourParams>();
  expect_sound_table<MeshParams>();
  expect_sound_table<RepairParams>();
  // ExportParams: the mesh's own up axis, root and skeleton are the caller's, and the twelve
  // attribute switches are one `attributes` row.
  expect_sound_table<ExportParams>(3 + 11);
  // Setting an integer from a number rounds and clamps to its type, above 2^63 too.
  ParticleParams p;
  const auto& seed = *std::find_if(param_table_of<ParticleParams>().fields.begin(),
                                   param_table_of<ParticleParams>().fields.end(),
                                   [](const auto& s) { return std::string(s.key) == "seed"; });
  set_param_value(p, seed, 1e19);
  EXPECT_EQ(p.seed, 10'000'000'000'000'000'000u);
  set_param_value(p, seed, 1e30);
  EXPECT_EQ(p.seed, std::numeric_limits<std::uint64_t>::max());
  set_param_value(p, seed, -3);
  EXPECT_EQ(p.seed, 0u);
  set_param_value(p, seed, 6.5);
  EXPECT_EQ(p.seed, 7u);
}

TEST(Pipeline, ParamsReferenceListsEveryKey) {
  const std::string md = params_reference(true);
  const auto j = nlohmann::json::parse(params_to_json(PipelineParams{}));
  for (const auto& [section, keys] : j.items()) {
    if (section == "export") continue;
    EXPECT_NE(md.find("### " + section + "\n"), std::string::npos) << section;
    for (const auto& [key, value] : keys.items()) {
      EXPECT_NE(md.find("| `" + key + "` | " + value.dump() + " |"), std::string::npos) << section << "." << key;
    }
  }
}

}  // namespace
}  // namespace sm
