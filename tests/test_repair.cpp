// The repair stage and its self-union, on inputs built in code.

#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>

#include "fixtures.h"
#include "mesh_fixtures.h"
#include "meshcheck/checks.h"
#include "meshcheck/intersections.h"
#include "pipeline/pipeline.h"
#include "repair/repair.h"
#include "repair/self_union.h"
#include "repair/verdict.h"
#include "grow/messy_grower.h"
#include "skeleton/build.h"
#include "skeleton/io.h"

#include <tbb/global_control.h>

namespace sm {
namespace {

std::vector<std::array<std::uint32_t, 2>> all_pairs(const Mesh& m) {
  std::vector<std::uint32_t> all(m.triangles.size());
  std::iota(all.begin(), all.end(), 0u);
  return TriangleIntersections(m).pairs(all);
}

TEST(SelfUnion, InterpenetratingBoxesBecomeTheirUnion) {
  // Two unit cubes overlapping in a cube of side 1/2: the union is one closed surface of
  // volume 2 - 1/8, with the eight corners of each cube inside the other gone.
  Mesh m = test::interpenetrating_boxes();
  const auto pairs = all_pairs(m);
  ASSERT_GT(pairs.size(), 0u);
  std::vector<std::uint32_t> origin;
  const SelfUnionStats st = self_union(m, pairs, 0.0, {}, origin);
  EXPECT_TRUE(st.problem.empty()) << st.problem;
  EXPECT_EQ(origin.size(), m.triangles.size());
  const MeshCheckReport r = check_mesh(m);
  EXPECT_TRUE(r.ok()) << to_text(r);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  EXPECT_NEAR(r.signed_volume, 2.0 - 0.125, 1e-12);
}

TEST(SelfUnion, PairsTouchingASubsetAreThoseOfTheWholeSearch) {
  // The repair recounts pairs only around the triangles an edit changed: pairs_touching(S)
  // must be exactly the whole search's pairs with a triangle in S, for any S.
  const Mesh m = test::interpenetrating_boxes();
  const auto all = all_pairs(m);
  ASSERT_GT(all.size(), 0u);
  const TriangleIntersections ti(m);
  for (std::uint32_t step : {1u, 2u, 3u, 7u}) {
    std::vector<std::uint32_t> subset;
    for (std::uint32_t f = 0; f < m.triangles.size(); f += step) subset.push_back(f);
    std::vector<std::array<std::uint32_t, 2>> expected;
    for (const auto& pr : all) {
      if (pr[0] % step == 0 || pr[1] % step == 0) expected.push_back(pr);
    }
    EXPECT_EQ(ti.pairs_touching(subset), expected) << "every " << step << "th triangle";
  }
  EXPECT_TRUE(ti.pairs_touching({}).empty());
}

TEST(SelfUnion, PairsOfALargeMeshAreTheSameAtGeoreferencedCoordinates) {
  // 2,025 pairs of interpenetrating boxes (48,600 triangles: the searches split into slabs on
  // all threads), at the origin and moved to UTM coordinates, where a float's step is half a
  // metre (the boxes of the search are taken about a vertex of the mesh): the same pairs, and
  // pairs_touching(S) the whole search's pairs with a triangle in S.
  const Mesh pair = test::interpenetrating_boxes();
  Mesh lattice;
  for (int i = 0; i < 45; ++i) {
    for (int j = 0; j < 45; ++j) {
      const auto base = static_cast<std::uint32_t>(lattice.positions.size());
      for (const glm::dvec3& p : pair.positions) lattice.positions.push_back(p + glm::dvec3(3 * i, 3 * j, 0.25 * (i % 3)));
      for (Mesh::Triangle t : pair.triangles) {
        for (std::uint32_t& v : t) v += base;
        lattice.triangles.push_back(t);
      }
    }
  }
  const auto at_origin = all_pairs(lattice);
  ASSERT_EQ(at_origin.size(), 45u * 45u * all_pairs(pair).size());
  const Mesh far = test::translated(lattice, glm::dvec3(500000, 5200000, 300));  // (exact in double)
  EXPECT_EQ(all_pairs(far), at_origin);
  const TriangleIntersections ti(far);
  std::vector<std::uint32_t> subset;
  for (std::uint32_t f = 0; f < far.triangles.size(); f += 3) subset.push_back(f);
  std::vector<std::array<std::uint32_t, 2>> expected;
  for (const auto& pr : at_origin) {
    if (pr[0] % 3 == 0 || pr[1] % 3 == 0) expected.push_back(pr);
  }
  EXPECT_EQ(ti.pairs_touching(subset), expected);
}

TEST(SelfUnion, DisjointPartsAreLeftAsTheyAre) {
  // No pairs: nothing to do, the mesh and the identity origin come back.
  Mesh m = test::box();
  const Mesh before = m;
  std::vector<std::uint32_t> origin;
  const SelfUnionStats st = self_union(m, {}, 0.0, {}, origin);
  EXPECT_TRUE(st.problem.empty());
  EXPECT_EQ(m.triangles, before.triangles);
  ASSERT_EQ(origin.size(), m.triangles.size());
  for (std::uint32_t f = 0; f < origin.size(); ++f) EXPECT_EQ(origin[f], f);
}

TEST(Repair, OneRuleKeepsOnlyABetterMesh) {
  const MeshFigures before{.parts = 1, .genus = 0, .volume = 1.0, .pairs = 10, .thick_inside = 50};
  auto with = [&](auto edit) {
    MeshFigures f = before;
    edit(f);
    return f;
  };
  EXPECT_EQ(refuse(before, with([](MeshFigures& f) { f.pairs = 4; })), "");
  EXPECT_EQ(refuse(before, with([](MeshFigures& f) { f.thick_inside = 51; })), "");
  EXPECT_EQ(refuse(before, before), "no fewer pairs and no more nodes inside");
  EXPECT_EQ(refuse(before, with([](MeshFigures& f) { f.pairs = 4; f.sound = false; })),
            "not a closed, oriented 2-manifold");
  EXPECT_EQ(refuse(before, with([](MeshFigures& f) { f.pairs = 4; f.parts = 2; })), "2 components");
  EXPECT_EQ(refuse(before, with([](MeshFigures& f) { f.pairs = 4; f.thick_inside = 49; })),
            "1 more thick nodes outside");
  EXPECT_EQ(refuse(before, with([](MeshFigures& f) { f.pairs = 4; f.volume = -1; })), "negative volume");
  // A handle: refused unless allowed (the self-union makes one where crossings close a loop).
  const MeshFigures handle = with([](MeshFigures& f) { f.pairs = 0; f.genus = 1; });
  EXPECT_EQ(refuse(before, handle), "genus 1");
  EXPECT_EQ(refuse(before, handle, {.handles_allowed = true}), "");
  // Figures a step does not measure are not compared.
  EXPECT_EQ(refuse(before, with([](MeshFigures& f) { f.pairs = 4; f.thick_inside.reset(); })), "");
  // All nodes inside, where both count them (the pass for thin nodes outside): more is better,
  // fewer is worse even with fewer pairs.
  const MeshFigures counted = with([](MeshFigures& f) { f.nodes_inside = 90; });
  auto from_counted = [&](auto edit) {
    MeshFigures f = counted;
    edit(f);
    return f;
  };
  EXPECT_EQ(refuse(counted, from_counted([](MeshFigures& f) { f.nodes_inside = 91; })), "");
  EXPECT_EQ(refuse(counted, from_counted([](MeshFigures& f) { f.pairs = 4; f.nodes_inside = 89; })),
            "1 more nodes outside");
  EXPECT_EQ(refuse(before, from_counted([](MeshFigures&) {})), "no fewer pairs and no more nodes inside");
}

TEST(Repair, CleanMeshIsUnchanged) {
  MeshResult r;
  r.mesh = test::icosphere(2);
  r.triangle_kind.assign(r.mesh.triangle_count(), TriangleKind::strip);
  const Mesh before = r.mesh;
  const RepairStats st = repair_crossings(r, test::built(test::straight_branch()));
  EXPECT_TRUE(st.counted);
  EXPECT_EQ(st.pairs_found, 0u);
  EXPECT_EQ(st.rounds, 0u);
  EXPECT_EQ(r.mesh.positions, before.positions);
  EXPECT_EQ(r.mesh.triangles, before.triangles);
}

TEST(Repair, CrossingBranchesFuseWhereTheyAreWithAHandle) {
  // Two laterals from different forks of a trunk cross each other away from their forks: with
  // the input kept (no separation), the mesh is their union, in place: closed, one part, no
  // self-intersections, and the loop trunk - lateral - crossing - lateral - trunk is a handle.
  const RawSkeleton raw = test::crossing_laterals();
  PipelineParams p;
  // (With collar nodes: without them the union here drops a piece of a lateral as a loose lump
  // and the handle is lost; open, docs/repair.md.)
  p.skeleton.collar_ratio = 0.7;
  const PipelineResult r = run_pipeline(raw, p);
  // The skeleton is where the file put it.
  EXPECT_EQ(r.skeleton.report.max_move, 0.0);
  const MeshCheckReport rep = check_mesh(r.mesh.mesh);
  EXPECT_TRUE(rep.closed);
  EXPECT_TRUE(rep.edge_manifold);
  EXPECT_TRUE(rep.oriented);
  EXPECT_EQ(rep.components, 1u);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_GT(r.repair.pairs_found, 0u);
  EXPECT_EQ(r.repair.pairs_left, 0u);
  ASSERT_TRUE(rep.genus.has_value());
  EXPECT_EQ(*rep.genus, 1);
  // `check --skeleton` finds the same genus implied by the input's crossing (implied_genus.h).
  const Skeleton input = input_skeleton(raw);
  const MeshCheckReport with_input =
      check_mesh(r.mesh.mesh, {.self_intersections = false, .skeleton = &input, .implied_genus = true});
  EXPECT_EQ(with_input.implied_genus, 1);
  EXPECT_EQ(with_input.genus_agrees(), std::optional<bool>(true));
}


/// The pipeline with the input kept: no separation, radii as given.
PipelineParams keep_input() {
  PipelineParams p;
  p.skeleton.separate = false;
  p.skeleton.thick_child_policy = ThickChildPolicy::keep;
  p.repair.fork_retry = false;
  p.repair.outer_surface = false;
  return p;
}

// `raw` meshed with the input kept, checked against the input: with the volume patch around
// thick nodes left outside (repair.patch_uncovered) off, then on.
/// The meshes of `raw` with the repair's `pass` off and on (the rest as `params`), each checked
/// against the input skeleton.
std::pair<MeshCheckReport, MeshCheckReport> checked_without_and_with(const RawSkeleton& raw, bool RepairParams::*pass,
                                                                     const PipelineParams& params) {
  const Skeleton input = input_skeleton(raw);
  auto check = [&](bool on) {
    PipelineParams p = params;
    p.repair.*pass = on;
    return check_mesh(run_pipeline(raw, p).mesh.mesh, {.skeleton = &input});
  };
  return {check(false), check(true)};
}

std::pair<MeshCheckReport, MeshCheckReport> checked_without_and_with_node_patches(const RawSkeleton& raw) {
  return checked_without_and_with(raw, &RepairParams::patch_uncovered, keep_input());
}

/// Closed, manifold, oriented, one part; no node moved beyond max_node_move; the thick nodes of
/// the input inside; returns the report measured against the input skeleton.
MeshCheckReport expect_faithful(const RawSkeleton& raw, const PipelineResult& r, const PipelineParams& p) {
  EXPECT_LE(r.skeleton.report.max_move_radii, p.skeleton.max_node_move + 1e-9);
  const Skeleton input = input_skeleton(raw);
  const MeshCheckReport rep = check_mesh(r.mesh.mesh, {.skeleton = &input});
  EXPECT_TRUE(rep.closed);
  EXPECT_TRUE(rep.edge_manifold);
  EXPECT_TRUE(rep.vertex_manifold);
  EXPECT_TRUE(rep.oriented);
  EXPECT_EQ(rep.components, 1u);
  EXPECT_GT(rep.signed_volume, 0);
  EXPECT_GE(double(rep.thick_nodes_inside), 0.97 * double(rep.thick_nodes));
  return rep;
}

/// A messy generator tree as `strandmesh grow --messy --seed N` writes it (the file's rounding
/// keeps nodes that the grown tree's zero-length edges merge).
RawSkeleton messy_as_written(std::uint64_t seed) {
  MessyGrowParams g;
  g.seed = seed;
  return parse_skeleton_json(raw_skeleton_to_json(grow_messy(g)));
}

/// Closed, manifold, oriented, one part.
void expect_sound_one_part(const MeshCheckReport& r) {
  EXPECT_TRUE(r.closed && r.edge_manifold && r.vertex_manifold && r.oriented);
  EXPECT_EQ(r.components, 1u);
}

TEST(Repair, VolumePatchAloneFusesCrossingBranches) {
  // The crossing of CrossingBranchesFuseWhereTheyAreWithAHandle with the self-union off: the
  // volume patch alone replaces the crossing by the round cones' union, stitched into the
  // surface: closed, one part, no self-intersections, the handle kept, faithful to the input.
  const RawSkeleton raw = test::crossing_laterals();
  PipelineParams p = keep_input();
  p.repair.self_union = false;
  p.repair.volume_patch = true;
  const PipelineResult r = run_pipeline(raw, p);
  EXPECT_GT(r.repair.pairs_found, 0u);
  EXPECT_GE(r.repair.patched, 1u);
  EXPECT_EQ(r.repair.pairs_left, 0u);
  const MeshCheckReport rep = expect_faithful(raw, r, p);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  ASSERT_TRUE(rep.genus.has_value());
  EXPECT_EQ(*rep.genus, 1);
  EXPECT_LE(rep.fidelity_p95, 0.15);
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
}

TEST(Repair, VolumePatchDrawsTwigsThinnerThanItsVoxels) {
  // The crossing above with a twig four times thinner than the laterals leaving at the crossing
  // point, and a grid too coarse for it: drawn at 1.25 voxels inside the patch, it keeps its
  // rim and the crossing is patched; with that off the region is not patched at all.
  RawSkeleton raw = test::crossing_laterals();
  raw.add(8, 4, dvec3(0.7, -0.25, 1.6), 0.008);
  PipelineParams p = keep_input();
  p.repair.self_union = false;
  p.repair.volume_patch = true;
  p.repair.patch_max_voxels = 200'000;
  p.repair.patch_min_twig_voxels = 0;
  const PipelineResult off = run_pipeline(raw, p);
  EXPECT_GT(off.repair.pairs_left, 0u);
  p.repair.patch_min_twig_voxels = 1.25;
  const PipelineResult r = run_pipeline(raw, p);
  EXPECT_GE(r.repair.patched, 1u);
  EXPECT_EQ(r.repair.pairs_left, 0u);
  const MeshCheckReport rep = expect_faithful(raw, r, p);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_EQ(rep.nodes_inside, rep.nodes);
  // (The grid is made coarse here: the patch is a large share of this small mesh and rounds
  // its crotch by about a voxel.)
  EXPECT_LE(rep.fidelity_p95, 0.2);
}

TEST(Repair, HairpinStaysWhereItIs) {
  // A lateral that runs out and turns back by 150 degrees, past its own base: kept in place
  // (not re-attached), meshed as one closed part.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0, 0, 0), 0.08);
  raw.add(1, 0, dvec3(0, 0, 1.0), 0.07);
  raw.add(2, 1, dvec3(0, 0, 2.0), 0.06);
  raw.add(3, 1, dvec3(0.5, 0, 1.2), 0.03);
  const double t = 150.0 * 3.14159265358979 / 180.0;  // the turn from the incoming edge
  const dvec3 in = glm::normalize(dvec3(0.5, 0, 0.2));
  const dvec3 side(0, 1, 0);  // it turns back beside the trunk, not into it
  raw.add(4, 3, dvec3(0.5, 0, 1.2) + 0.4 * (std::cos(t) * in + std::sin(t) * side), 0.025);
  raw.add(5, 4, raw.position[4] + 0.3 * (std::cos(t) * in + std::sin(t) * side), 0.02);
  PipelineParams p = keep_input();
  const PipelineResult r = run_pipeline(raw, p);
  const MeshCheckReport rep = expect_faithful(raw, r, p);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  // (p50: on a tree this small the flat caps' inner vertices, up to a radius from the round
  // cones' surface, are more than 5 % of the vertices.)
  EXPECT_LE(rep.fidelity_p50, 0.05);
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
}

TEST(Repair, HubOfTwigsIsOnePartInPlace) {
  // Twenty twigs from one trunk node, some crossing each other: one closed part, nothing
  // moved beyond the bound.
  RawSkeleton raw = test::star(20);
  const PipelineParams p = keep_input();
  const PipelineResult r = run_pipeline(raw, p);
  const MeshCheckReport rep = expect_faithful(raw, r, p);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
}

TEST(Repair, ZeroRadiusFirIsMeshedAtTheFloor) {
  // A fir as Sapling writes it: whorls of near-horizontal branches whose outer nodes have
  // radius 0, raised to the radius floor (not dropped): every node is kept.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0), 0.1);
  std::int64_t id = 1, below = 0;
  for (int w = 1; w <= 4; ++w) {
    const double z = 0.8 * w, rt = 0.1 * (1.0 - 0.2 * w);
    raw.add(id, below, dvec3(0, 0, z), rt);
    const std::int64_t node = id++;
    for (int k = 0; k < 4; ++k) {
      const double a = 1.5707963 * k + 0.4 * w;
      const dvec3 d(std::cos(a), std::sin(a), -0.05);
      raw.add(id, node, dvec3(0, 0, z) + 0.3 * d, 0.3 * rt);
      raw.add(id + 1, id, dvec3(0, 0, z) + 0.6 * d, 0.0);
      raw.add(id + 2, id + 1, dvec3(0, 0, z) + 0.8 * d, 0.0);
      id += 3;
    }
    below = node;
  }
  raw.add(id, below, dvec3(0, 0, 4.0), 0.01);
  const PipelineParams p = keep_input();
  const PipelineResult r = run_pipeline(raw, p);
  EXPECT_EQ(r.skeleton.report.dropped_nodes, 0u);
  const MeshCheckReport rep = expect_faithful(raw, r, p);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
}

TEST(Repair, KinkOfAFractionOfARadiusMeshesWithoutCrossingLoops) {
  // mtg_boutdenoylum2 as given has digitised kinks (nodes 156-158: a 0.6-radius edge turning
  // back by 108 degrees, then on at 69 degrees). Slices on either side of one cross inside the
  // branch and the strip between them turns inside out, which cut a twig off in the union;
  // the crossing loops are left out of their tubes, so no two consecutive loops cross and the
  // mesh is clean where the input put it.
  std::optional<std::filesystem::path> file;
  for (const auto& f : test::sample_skeletons()) {
    if (f.filename() == "mtg_boutdenoylum2.json") file = f;
  }
  ASSERT_TRUE(file) << "sample skeleton missing from tests/data/skeletons";
  const RawSkeleton raw = read_skeleton(*file);
  PipelineParams p = keep_input();
  const PipelineResult r = run_pipeline(raw, p);
  EXPECT_GT(r.contours.stats.uncrossed_loops, 0u);
  const ContourSet& c = r.contours;
  for (const Tube& t : c.tubes) {
    // (From the second loop on: the first lies in its fork's section, tilted against the branch.)
    for (std::size_t k = 2; k < t.loops.size(); ++k) {
      // Every point of a loop in front of the previous loop's plane (within the tolerance).
      const std::uint32_t a = t.loops[k - 1], b = t.loops[k];
      // (Loops farther apart than uncross_reach radii are exempt by contract: the kept 1.2-radius
      // hairpin at input nodes 31-32 tilts one loop against another 9 radii on.)
      const double apart = std::abs(c.loop_distance[b] - c.loop_distance[a]);
      if (apart > p.contours.uncross_reach * std::max(c.loop_radius[a], c.loop_radius[b])) continue;
      dvec3 centre(0), normal(0);
      for (std::uint32_t v = c.loop_begin[a]; v < c.loop_begin[a + 1]; ++v) {
        const std::uint32_t w = v + 1 < c.loop_begin[a + 1] ? v + 1 : c.loop_begin[a];
        centre += c.point[v];
        normal += glm::cross(c.point[v] - c.loop_center[a], c.point[w] - c.loop_center[a]);
      }
      centre /= double(c.loop_size(a));
      if (glm::dot(normal, c.loop_frame[a].tangent) < 0) normal = -normal;
      normal = glm::normalize(normal);
      for (std::uint32_t v = c.loop_begin[b]; v < c.loop_begin[b + 1]; ++v) {
        EXPECT_GE(glm::dot(c.point[v] - centre, normal),
                  -p.contours.uncross_tolerance * std::max(c.loop_radius[a], c.loop_radius[b]) - 1e-9);
      }
    }
  }
  // (Not yet every thick node inside: 113-115 of 120, docs/repair.md.)
  const Skeleton input = input_skeleton(raw);
  const MeshCheckReport rep = check_mesh(r.mesh.mesh, {.skeleton = &input});
  EXPECT_TRUE(rep.closed && rep.edge_manifold && rep.vertex_manifold && rep.oriented);
  EXPECT_EQ(rep.components, 1u);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_LE(r.skeleton.report.max_move_radii, p.skeleton.max_node_move + 1e-9);
  // Without it the strip folds there.
  PipelineParams crossing = p;
  crossing.contours.uncross_loops = false;
  crossing.repair.self_union = false;
  crossing.repair.fold_rounds = 0;
  const PipelineResult f = run_pipeline(raw, crossing);
  EXPECT_EQ(f.contours.stats.uncrossed_loops, 0u);
  EXPECT_GT(check_mesh(f.mesh.mesh).self_intersecting_pairs, 0u);
}

TEST(Repair, FaithfulConfigMeshesTheTreeAsGiven) {
  // configs/faithful.json: no separation, radii as given, no collar nodes, no raised lateral
  // bases. A messy tree meshes as one closed part within 0.15 of the local radius of the input's
  // round cones at the 95th percentile, no node moved beyond max_node_move.
  const PipelineParams p = load_params(std::filesystem::path(STRANDMESH_SOURCE_DIR) / "configs/faithful.json");
  EXPECT_FALSE(p.skeleton.separate);
  EXPECT_EQ(p.skeleton.thick_child_policy, ThickChildPolicy::keep);
  EXPECT_EQ(p.skeleton.collar_ratio, 0.0);
  EXPECT_EQ(p.skeleton.max_lateral_angle, 0.0);
  MessyGrowParams g;
  g.seed = 1;
  const RawSkeleton raw = grow_messy(g);
  const PipelineResult r = run_pipeline(raw, p);
  EXPECT_LE(r.skeleton.report.max_move_radii, p.skeleton.max_node_move + 1e-9);
  const Skeleton input = input_skeleton(raw);
  const MeshCheckReport rep = check_mesh(r.mesh.mesh, {.skeleton = &input});
  EXPECT_TRUE(rep.closed && rep.edge_manifold && rep.vertex_manifold && rep.oriented);
  EXPECT_EQ(rep.components, 1u);
  EXPECT_LE(rep.fidelity_p95, 0.15);
  // Every input node counted by winding number, the thick ones among them.
  EXPECT_EQ(rep.nodes, input.size());
  EXPECT_GE(rep.nodes_inside, rep.thick_nodes_inside);
  EXPECT_GE(double(rep.nodes_inside), 0.9 * double(rep.nodes));
  // (Not yet free of self-intersections on every tree: docs/repair.md.)
  EXPECT_LT(rep.self_intersecting_pairs, 100u);
}

TEST(Repair, MessyTreesStayOnePartAndInPlace) {
  // Generator trees (crossing and hanging limbs, zigzags, a hub, hairpins, zero radii, thick
  // children) at fixed seeds, one of them georeferenced: the mesh is one closed part in place.
  for (const std::uint64_t seed : {1u, 2u}) {
    MessyGrowParams g;
    g.seed = seed;
    if (seed == 2) g.origin = dvec3(500'000, 5'200'000, 300);
    const RawSkeleton raw = grow_messy(g);
    const PipelineParams p = keep_input();
    const PipelineResult r = run_pipeline(raw, p);
    SCOPED_TRACE("messy seed " + std::to_string(seed));
    // (Not yet every thick node inside, nor free of self-intersections: docs/repair.md.)
    const MeshCheckReport rep = expect_faithful(raw, r, p);
    EXPECT_LT(rep.self_intersecting_pairs, 1000u);
  }
}

TEST(Repair, VolumePatchCoversThickNodesLeftOutside) {
  // Messy seed 154: a thick node the slicing leaves outside its crotch. The patch pass around
  // such nodes (repair.patch_uncovered) draws the input's round cones there: more thick input
  // nodes inside, no more pairs, still one closed part.
  MessyGrowParams g;
  g.seed = 154;
  const RawSkeleton raw = grow_messy(g);
  const auto [off, on] = checked_without_and_with_node_patches(raw);
  EXPECT_GT(on.thick_nodes_inside, off.thick_nodes_inside);
  EXPECT_LE(on.self_intersecting_pairs, off.self_intersecting_pairs);
  EXPECT_TRUE(on.closed && on.edge_manifold && on.vertex_manifold && on.oriented);
  EXPECT_EQ(on.components, 1u);
}

TEST(Repair, VolumePatchCoversThinNodesLeftOutsideAtAHub) {
  // Messy seed 222: a hub of twelve twigs whose first nodes the slicing's webs leave outside.
  // The pass for every node still outside (repair.patch_uncovered_thin) draws the input's round
  // cones there: more input nodes inside, no fewer thick ones, no more pairs, the same genus.
  // (As `strandmesh grow --messy --seed 222` writes it: the file's rounding keeps two nodes
  // that the grown tree's zero-length edges merge.)
  const RawSkeleton raw = messy_as_written(222);
  const auto [off, on] = checked_without_and_with(raw, &RepairParams::patch_uncovered_thin, PipelineParams{});
  EXPECT_GE(double(on.nodes_inside), double(off.nodes_inside) + 5);
  EXPECT_GE(double(on.nodes_inside), 0.99 * double(on.nodes));
  EXPECT_GE(on.thick_nodes_inside, off.thick_nodes_inside);
  EXPECT_LE(on.self_intersecting_pairs, off.self_intersecting_pairs);
  EXPECT_EQ(on.genus, off.genus);
  EXPECT_LE(on.fidelity_p95, 0.1);
  EXPECT_TRUE(on.closed && on.edge_manifold && on.vertex_manifold && on.oriented);
  EXPECT_EQ(on.components, 1u);
}

TEST(Repair, VolumePatchPassForThePairsLeftRemovesThem) {
  // Messy seeds 301 and 327 keep a few pairs after the patch passes for the crossings and the
  // nodes outside: their regions' faces cut two surfaces a voxel apart, and no patch's rims
  // matched its holes. The pass for the pairs left (repair.patch_left) draws regions around
  // them as the surface is now: no pair left, and nothing the check measures against the input
  // is worse. (Seed 327 was grown after the tuning.)
  for (const std::uint64_t seed : {301u, 327u}) {
    SCOPED_TRACE("messy seed " + std::to_string(seed));
    const auto [off, on] =
        checked_without_and_with(messy_as_written(seed), &RepairParams::patch_left, PipelineParams{});
    EXPECT_GT(off.self_intersecting_pairs, 0u);
    EXPECT_EQ(on.self_intersecting_pairs, 0u);
    EXPECT_GE(on.nodes_inside, off.nodes_inside);
    EXPECT_GE(on.thick_nodes_inside, off.thick_nodes_inside);
    EXPECT_LE(on.fidelity_p95, std::max(off.fidelity_p95, 0.15));
    expect_sound_one_part(on);
  }
}

TEST(Repair, SeamsOfThePassForThinNodesArePatchedBeforeItIsJudged) {
  // Messy seed 329 (grown after the tuning): a hub of fourteen twigs whose first nodes the
  // slicing's webs leave outside. The pass for thin nodes patches them, but its seams leave
  // pairs, and without another round around those it is refused. With it (repair.patch_left):
  // every input node inside, no pair, fidelity no worse.
  const auto [off, on] =
      checked_without_and_with(messy_as_written(329), &RepairParams::patch_left, PipelineParams{});
  EXPECT_LT(off.nodes_inside, off.nodes);
  EXPECT_EQ(on.nodes_inside, on.nodes);
  EXPECT_EQ(on.self_intersecting_pairs, 0u);
  EXPECT_GE(on.thick_nodes_inside, off.thick_nodes_inside);
  EXPECT_LE(on.fidelity_p95, std::max(off.fidelity_p95, 0.1));
  expect_sound_one_part(on);
}

TEST(Repair, VolumePatchPassForThePairsLeftIsTheSameForAnyThreadCount) {
  const RawSkeleton raw = messy_as_written(301);
  auto mesh_of = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const PipelineResult r = run_pipeline(raw, PipelineParams{});
    return std::pair(r.mesh.mesh.positions, r.mesh.mesh.triangles);
  };
  const auto one = mesh_of(1), two = mesh_of(2);
  EXPECT_TRUE(two.first == one.first);
  EXPECT_TRUE(two.second == one.second);
}

TEST(Repair, FirWhorlWithALateralRunningBackIsRoundAndHoldsItsNodes) {
  // The whorl at input node 21 of skeletons-large/sapling_douglas_fir_s202.json (its nodes 19 and
  // 20 and node 20's subtree three edges deep, positions and radii as in the file): five
  // children at one node, one of them (449) running back along the parent's edge, thicker than
  // the node. The slicing left flat shards there and three thick nodes outside; the patch
  // around the thick nodes outside (repair.patch_uncovered) draws the input's round cones.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(-1.257509, -0.099827, 15.576056), 0.049096);
  raw.add(1, 0, dvec3(-2.550853, -0.141528, 14.812113), 0.035047);
  raw.add(2, 1, dvec3(-3.84034, -0.266595, 14.050754), 0.020999);
  raw.add(3, 2, dvec3(-5.190951, 0.083097, 13.492497), 0.006951);
  raw.add(4, 3, dvec3(-5.190951, 0.083097, 13.492497), 0.006951);
  raw.add(5, 3, dvec3(-5.117665, 0.225573, 13.608824), 0.006335);
  raw.add(6, 2, dvec3(-3.84034, -0.266595, 14.050754), 0.020999);
  raw.add(7, 6, dvec3(-5.320696, -0.609495, 13.639768), 0.006951);
  raw.add(8, 2, dvec3(-3.424368, -0.265178, 14.275424), 0.022836);
  raw.add(9, 8, dvec3(-3.872296, 0.150252, 13.745593), 0.015891);
  raw.add(10, 2, dvec3(-4.059592, -0.239155, 13.945535), 0.018919);
  raw.add(11, 10, dvec3(-4.525748, -0.55404, 13.637113), 0.013279);
  raw.add(12, 10, dvec3(-4.045272, -0.314064, 13.993859), 0.019013);
  raw.add(13, 2, dvec3(-3.633552, -0.073153, 14.010883), 0.005252);
  raw.add(14, 13, dvec3(-3.735335, -0.136444, 13.73508), 0.003626);
  raw.add(15, 1, dvec3(-2.268201, -0.126576, 14.975736), 0.029776);
  raw.add(16, 15, dvec3(-2.850949, 0.516562, 14.092163), 0.020518);
  raw.add(17, 16, dvec3(-3.526835, 1.290161, 13.400322), 0.011259);
  raw.add(18, 16, dvec3(-2.751105, 0.404661, 14.222979), 0.009652);
  raw.add(19, 16, dvec3(-3.044823, 0.736471, 13.862392), 0.01067);
  raw.add(20, 1, dvec3(-2.889845, -0.180796, 14.605329), 0.026268);
  raw.add(21, 20, dvec3(-3.167312, -0.705525, 14.169283), 0.018179);
  raw.add(22, 21, dvec3(-3.504245, -1.290265, 13.874292), 0.010089);
  raw.add(23, 21, dvec3(-3.118795, -0.617016, 14.231025), 0.008515);
  raw.add(24, 21, dvec3(-3.262978, -0.875229, 14.063292), 0.009413);
  raw.add(25, 1, dvec3(-2.501355, 0.129031, 14.601654), 0.006307);
  raw.add(26, 25, dvec3(-2.704303, -0.017046, 14.144723), 0.004153);
  raw.add(27, 26, dvec3(-2.983052, -0.169323, 13.7319), 0.0);
  const auto [off, on] = checked_without_and_with_node_patches(raw);
  EXPECT_LT(off.thick_nodes_inside, off.thick_nodes);
  EXPECT_EQ(on.thick_nodes_inside, on.thick_nodes);
  EXPECT_LT(on.self_intersecting_pairs, off.self_intersecting_pairs);
  EXPECT_LE(on.fidelity_p95, 0.15);
  EXPECT_TRUE(on.closed && on.edge_manifold && on.vertex_manifold && on.oriented);
  EXPECT_EQ(on.components, 1u);
}

TEST(Repair, SelfUnionIsTheSameForAnyThreadCount) {
  // CGAL returns the refined triangles in an order that depends on heap addresses; messy seed
  // 104 at UTM coordinates gave another mesh about one run in three on two threads before the
  // refinement's output was put in a canonical order.
  MessyGrowParams g;
  g.seed = 104;
  g.origin = dvec3(500'000, 5'200'000, 300);
  const RawSkeleton raw = grow_messy(g);
  const PipelineParams p = keep_input();
  auto mesh_of = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const PipelineResult r = run_pipeline(raw, p);
    EXPECT_GT(r.repair.rounds, 0u);
    return std::pair(r.mesh.mesh.positions, r.mesh.mesh.triangles);
  };
  const auto one = mesh_of(1);
  for (int run = 0; run < 3; ++run) {
    const auto two = mesh_of(2);
    EXPECT_TRUE(two.first == one.first) << "positions differ, run " << run;
    EXPECT_TRUE(two.second == one.second) << "triangles differ, run " << run;
  }
}

// ---------------------------------------------------------------- collars

/// A trunk with a thinner lateral leaving it at 60 degrees, and the Y fork of the fixtures.
RawSkeleton trunk_with_lateral() {
  RawSkeleton raw;
  raw.source = "trunk_with_lateral";
  for (int i = 0; i < 5; ++i) raw.add(i, i - 1, dvec3(0, 0, 0.5 * i), 0.1 - 0.005 * i);
  const double a = 60.0 * std::numbers::pi / 180.0;
  const dvec3 d(std::sin(a), 0, std::cos(a));
  for (int i = 1; i <= 3; ++i) raw.add(10 + i, i == 1 ? 2 : 10 + i - 1, dvec3(0, 0, 1.0) + 0.4 * i * d, 0.045 - 0.005 * i);
  return raw;
}

TEST(Collars, SmoothTheJunctionsAndKeepTheMeshSoundAndFaithful) {
  // With repair.collars the junctions are remeshed and laid onto the smooth union of the round
  // cones: the dihedral angles at the junctions drop, and everything the repair guarantees
  // still holds: closed, oriented, one part, no pair, fidelity to the input, nodes inside, no
  // needle made.
  for (const RawSkeleton& raw : {trunk_with_lateral(), test::y_fork(35.0)}) {
    SCOPED_TRACE(raw.source);
    const Skeleton input = input_skeleton(raw);
    PipelineParams p;
    const PipelineResult off = run_pipeline(raw, p);
    p.repair.collars = true;
    const PipelineResult on = run_pipeline(raw, p);
    EXPECT_EQ(off.repair.collars.regions, 0u);
    EXPECT_GE(on.repair.collars.made, 1u);
    EXPECT_GT(on.repair.collars.triangles_after, on.repair.collars.triangles_before);
    const MeshCheckReport a = check_mesh(off.mesh.mesh, {.skeleton = &input});
    const MeshCheckReport b = check_mesh(on.mesh.mesh, {.skeleton = &input});
    EXPECT_TRUE(b.closed && b.edge_manifold && b.vertex_manifold && b.oriented);
    EXPECT_EQ(b.components, 1u);
    EXPECT_GT(b.signed_volume, 0);
    EXPECT_EQ(b.self_intersecting_pairs, 0u);
    EXPECT_LE(b.fidelity_p95, 0.15);
    EXPECT_EQ(b.thick_nodes_inside, b.thick_nodes);
    EXPECT_GE(b.nodes_inside, a.nodes_inside);
    EXPECT_LE(b.quality.under_1, a.quality.under_1);
    EXPECT_GT(b.triangles, a.triangles);
    EXPECT_LT(b.quality.junction_dihedral_p99, 0.75 * a.quality.junction_dihedral_p99);
  }
}

TEST(Collars, AreTheSameForAnyThreadCount) {
  const RawSkeleton raw = trunk_with_lateral();
  PipelineParams p;
  p.repair.collars = true;
  const PipelineResult one = [&] {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    return run_pipeline(raw, p);
  }();
  const PipelineResult two = [&] {
    const tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 2);
    return run_pipeline(raw, p);
  }();
  EXPECT_GE(one.repair.collars.made, 1u);
  EXPECT_TRUE(one.mesh.mesh.positions == two.mesh.mesh.positions);
  EXPECT_TRUE(one.mesh.mesh.triangles == two.mesh.mesh.triangles);
}

}  // namespace
}  // namespace sm
