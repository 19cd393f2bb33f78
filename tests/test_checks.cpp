// Mesh checks (meshcheck/checks.h) on meshes built in code, each with the report it must give,
// plus `strandmesh check` end to end.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numbers>
#include <random>

#include <nlohmann/json.hpp>
#include <sys/wait.h>

#include "core/errors.h"
#include "core/file_io.h"
#include "meshcheck/checks.h"
#include "meshcheck/implied_genus.h"
#include "meshio/export.h"
#include "skeleton/build.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"
#include "tests/mesh_fixtures.h"

namespace sm {
namespace {

namespace fs = std::filesystem;

bool mentions(const MeshCheckReport& r, const std::string& word) {
  for (const auto& f : r.failures()) {
    if (f.find(word) != std::string::npos) return true;
  }
  return false;
}

TEST(Checks, IcosphereIsAClosedGenusZeroManifold) {
  const Mesh m = test::icosphere(3);
  const MeshCheckReport r = check_mesh(m);
  EXPECT_EQ(r.vertices, 642u);
  EXPECT_EQ(r.triangles, 1280u);
  EXPECT_EQ(r.edges, 1920u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.edge_manifold);
  EXPECT_TRUE(r.vertex_manifold);
  EXPECT_TRUE(r.oriented);
  EXPECT_EQ(r.euler_characteristic, 2);
  ASSERT_TRUE(r.genus.has_value());
  EXPECT_EQ(*r.genus, 0);
  EXPECT_EQ(r.degenerate_triangles, 0u);
  EXPECT_TRUE(r.self_intersections_checked);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  EXPECT_GT(r.signed_volume, 0.95 * 4.0 / 3.0 * 3.14159265 * 0.95);
  EXPECT_LT(r.signed_volume, 4.0 / 3.0 * 3.14159266);
  EXPECT_TRUE(r.ok()) << to_text(r);
}

TEST(Checks, CappedTubeIsOk) {
  const MeshCheckReport r = check_mesh(test::capped_tube());
  EXPECT_TRUE(r.ok()) << to_text(r);
  EXPECT_EQ(r.euler_characteristic, 2);
}

TEST(Checks, TorusHasGenusOne) {
  const MeshCheckReport r = check_mesh(test::torus());
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.oriented);
  EXPECT_EQ(r.euler_characteristic, 0);
  ASSERT_TRUE(r.genus.has_value());
  EXPECT_EQ(*r.genus, 1);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  // A handle is what two branches crossing and fused make: not a defect.
  EXPECT_TRUE(r.ok()) << to_text(r);
  EXPECT_NE(to_text(r).find("genus                 1 (handles where branches cross and fuse)"), std::string::npos)
      << to_text(r);
}

TEST(Checks, TwoSpheresAreTwoComponents) {
  const MeshCheckReport r = check_mesh(test::two_spheres());
  EXPECT_EQ(r.components, 2u);
  EXPECT_EQ(r.euler_characteristic, 4);
  ASSERT_TRUE(r.genus.has_value());
  EXPECT_EQ(*r.genus, 0);
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r, "2 connected components"));
  EXPECT_EQ(r.failures().size(), 1u) << to_text(r);
}

TEST(Checks, FlippedTriangleIsNotOriented) {
  const MeshCheckReport r = check_mesh(test::box_with_flipped_triangle());
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.edge_manifold);
  EXPECT_FALSE(r.oriented);
  EXPECT_EQ(r.misoriented_edges, 3u);
  EXPECT_EQ(r.misoriented_edge_examples.size(), 3u);
  EXPECT_FALSE(r.genus.has_value());
  EXPECT_EQ(r.self_intersecting_pairs, 0u);  // the soup path: no false positives
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r, "misoriented"));
}

TEST(Checks, MissingTriangleIsNotClosed) {
  const MeshCheckReport r = check_mesh(test::box_with_missing_triangle());
  EXPECT_FALSE(r.closed);
  EXPECT_EQ(r.boundary_edges, 3u);
  EXPECT_TRUE(r.oriented);
  EXPECT_TRUE(r.vertex_manifold);
  EXPECT_FALSE(r.genus.has_value());
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r, "3 boundary edges"));
}

TEST(Checks, InterpenetratingBoxesSelfIntersect) {
  const Mesh m = test::interpenetrating_boxes();
  const MeshCheckReport r = check_mesh(m);
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.oriented);
  EXPECT_EQ(r.components, 2u);
  EXPECT_GT(r.self_intersecting_pairs, 0u);
  ASSERT_FALSE(r.self_intersection_examples.empty());
  for (const auto& p : r.self_intersection_examples) {
    EXPECT_LT(p[0], 12u);  // every pair has one triangle of each box
    EXPECT_GE(p[1], 12u);
  }
  EXPECT_TRUE(mentions(r, "self-intersecting"));

  // The same geometry with one triangle reversed is no polygon mesh, so it takes the
  // triangle-soup path; the pairs must be the same.
  Mesh flipped = m;
  std::swap(flipped.triangles[20][1], flipped.triangles[20][2]);
  const MeshCheckReport rf = check_mesh(flipped, {.max_examples = 1000});
  const MeshCheckReport rm = check_mesh(m, {.max_examples = 1000});
  EXPECT_FALSE(rf.oriented);
  EXPECT_EQ(rf.self_intersecting_pairs, r.self_intersecting_pairs);
  EXPECT_EQ(rf.self_intersection_examples, rm.self_intersection_examples);

  // Deterministic report, and the test can be skipped.
  EXPECT_EQ(check_mesh(m).self_intersection_examples, r.self_intersection_examples);
  const MeshCheckReport skipped = check_mesh(m, {.self_intersections = false});
  EXPECT_FALSE(skipped.self_intersections_checked);
  EXPECT_EQ(skipped.self_intersecting_pairs, 0u);
}

// CGAL's own test (the polygon-mesh path) and ours (the soup path, taken once triangle
// `reversed` is turned over) find the same pairs, at least `min_pairs` of them.
void expect_soup_path_agrees(const Mesh& m, std::size_t reversed, std::size_t min_pairs) {
  Mesh soup = m;
  std::swap(soup.triangles[reversed][1], soup.triangles[reversed][2]);
  const MeshCheckReport rm = check_mesh(m, {.max_examples = 1'000'000});
  const MeshCheckReport rs = check_mesh(soup, {.max_examples = 1'000'000});
  ASSERT_TRUE(rm.oriented);
  ASSERT_FALSE(rs.oriented);
  EXPECT_GT(rm.self_intersecting_pairs, min_pairs);
  EXPECT_EQ(rs.self_intersecting_pairs, rm.self_intersecting_pairs);
  EXPECT_EQ(rs.self_intersection_examples, rm.self_intersection_examples);
}

TEST(Checks, SoupPathAgreesWithCgalOnTangles) {
  // CGAL's own test (the polygon-mesh path) and ours (the soup path, taken once a triangle is
  // reversed; its floating-point shortcut included) must find the same pairs: on a sphere
  // jittered until neighbouring triangles fold through each other (pairs sharing a vertex or
  // an edge), and on two copies of it a few units in the last place apart (nearly coplanar
  // pairs, where rounding decides the sign of a determinant).
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> jitter(-0.15, 0.15);
  Mesh folded = test::icosphere(3);
  for (auto& p : folded.positions) p += glm::dvec3(jitter(rng), jitter(rng), jitter(rng));
  std::uniform_int_distribution<int> ulps(-3, 3);
  Mesh copy = folded;
  for (auto& p : copy.positions) {
    for (int k = 0; k < 3; ++k) {
      for (int u = ulps(rng); u != 0; u += u > 0 ? -1 : 1) p[k] = std::nextafter(p[k], u > 0 ? 10.0 : -10.0);
    }
  }
  for (const Mesh& m : {folded, test::merged(folded, copy)}) expect_soup_path_agrees(m, 5, 100);
}

TEST(Checks, SoupPathAgreesWithCgalOnFoldedPlanes) {
  // Triangles sharing a vertex or an edge in one plane, or a few units in the last place off
  // it, where the floating-point shortcuts (one side of a plane, an edge passing outside a
  // triangle, neighbours across an edge not coplanar) cannot decide and the exact tests must:
  // a flat grid jittered within its plane until neighbouring triangles overlap.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> jitter(-0.7, 0.7);
  std::uniform_int_distribution<int> ulps(-2, 2);
  constexpr std::uint32_t kSide = 24;
  for (const bool off_plane : {false, true}) {
    Mesh grid;
    for (std::uint32_t i = 0; i <= kSide; ++i) {
      for (std::uint32_t j = 0; j <= kSide; ++j) {
        double z = 0.25;
        for (int u = off_plane ? ulps(rng) : 0; u != 0; u += u > 0 ? -1 : 1) z = std::nextafter(z, u > 0 ? 1.0 : -1.0);
        grid.positions.emplace_back(double(i) + jitter(rng), double(j) + jitter(rng), z);
      }
    }
    for (std::uint32_t i = 0; i < kSide; ++i) {
      for (std::uint32_t j = 0; j < kSide; ++j) {
        const std::uint32_t v = i * (kSide + 1) + j;
        grid.triangles.push_back({v, v + kSide + 1, v + 1});
        grid.triangles.push_back({v + 1, v + kSide + 1, v + kSide + 2});
      }
    }
    expect_soup_path_agrees(grid, 11, 50);
  }
}

TEST(Checks, SoupPathAgreesWithCgalOnLargeMeshes) {
  // From 40,000 triangles the soup path searches slabs of space in parallel, each pair in the
  // slab where its boxes' overlap starts: two jittered spheres through each other (40,960
  // triangles; pairs along their intersection and where the jitter folds neighbours).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> jitter(-0.012, 0.012);
  Mesh a = test::icosphere(5);
  for (auto& p : a.positions) p += glm::dvec3(jitter(rng), jitter(rng), jitter(rng));
  const Mesh m = test::merged(a, test::icosphere(5, 0.9, glm::dvec3(0.5, 0.2, 0.1)));
  ASSERT_GE(m.triangles.size(), 40000u);
  expect_soup_path_agrees(m, 7, 500);
}

TEST(Checks, RayCrossingsAgreeWithTheWindingNumber) {
  // inside_closed_mesh, for one point and for many at once. Two overlapping jittered
  // spheres (winding number 2 where they overlap) and a box: random points, the mesh's own
  // vertices, edge midpoints and face centres (on the surface: the ray test falls back to the
  // winding number there) and points along the ray's axes.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> jitter(-0.02, 0.02), coord(-1.6, 2.2);
  Mesh a = test::icosphere(3);
  for (auto& p : a.positions) p += glm::dvec3(jitter(rng), jitter(rng), jitter(rng));
  Mesh b = test::icosphere(2, 0.8, glm::dvec3(0.7, 0.1, 0));
  const Mesh spheres = test::merged(a, b);
  for (const Mesh& m : {spheres, test::box(glm::dvec3(0), glm::dvec3(1))}) {
    std::vector<glm::dvec3> points;
    for (int i = 0; i < 2000; ++i) points.emplace_back(coord(rng), coord(rng), coord(rng));
    for (const auto& t : m.triangles) {
      const glm::dvec3 &p = m.positions[t[0]], &q = m.positions[t[1]], &r = m.positions[t[2]];
      points.push_back(p);
      points.push_back(0.5 * (p + q));
      points.push_back((p + q + r) / 3.0);
    }
    for (const double x : {0.0, 0.25, 0.5, 1.0}) points.emplace_back(x, x, x);
    std::size_t inside = 0;
    const std::vector<std::uint8_t> batch = inside_closed_mesh(m, points);  // and with the points binned
    ASSERT_EQ(batch.size(), points.size());
    for (std::size_t k = 0; k < points.size(); ++k) {
      const glm::dvec3& p = points[k];
      const bool expected = winding_number(m, p) >= 0.5;
      EXPECT_EQ(inside_closed_mesh(m, p), expected) << p.x << " " << p.y << " " << p.z;
      EXPECT_EQ(batch[k] == 1, expected) << p.x << " " << p.y << " " << p.z;
      inside += expected;
    }
    EXPECT_TRUE(inside_closed_mesh(m, std::vector<glm::dvec3>{}).empty());
    EXPECT_GT(inside, 20u);
    EXPECT_LT(inside, points.size() - 20);
  }
}

TEST(Checks, TouchingBoxesIntersectSeparateBoxesDoNot) {
  // Boxes that touch along a face through distinct vertices: the coplanar faces overlap.
  const Mesh touching =
      test::merged(test::box(glm::dvec3(0), glm::dvec3(1)), test::box(glm::dvec3(1, 0, 0), glm::dvec3(2, 1, 1)));
  EXPECT_GT(check_mesh(touching).self_intersecting_pairs, 0u);
  const Mesh apart =
      test::merged(test::box(glm::dvec3(0), glm::dvec3(1)), test::box(glm::dvec3(2, 0, 0), glm::dvec3(3, 1, 1)));
  EXPECT_EQ(check_mesh(apart).self_intersecting_pairs, 0u);
}

TEST(Checks, FoldedAndDuplicateTrianglesIntersect) {
  // Two triangles sharing an edge and folded flat onto the same side: they overlap.
  Mesh fold;
  fold.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5, 0.8, 0}};
  fold.triangles = {{0, 1, 2}, {1, 0, 3}};
  EXPECT_EQ(check_mesh(fold).self_intersecting_pairs, 1u);
  // Unfolded (the second on the other side of the edge): no intersection.
  fold.positions[3] = {0.5, -0.8, 0};
  EXPECT_EQ(check_mesh(fold).self_intersecting_pairs, 0u);
  // A duplicated triangle (soup path: its edges have four triangles).
  Mesh dup = test::box();
  dup.triangles.push_back(dup.triangles[0]);
  const MeshCheckReport r = check_mesh(dup);
  EXPECT_FALSE(r.edge_manifold);
  EXPECT_EQ(r.self_intersecting_pairs, 1u);
}

TEST(Checks, DegenerateTriangleIsCounted) {
  const MeshCheckReport r = check_mesh(test::box_with_degenerate_triangle());
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.edge_manifold);
  EXPECT_TRUE(r.oriented);
  EXPECT_EQ(r.degenerate_triangles, 1u);
  ASSERT_EQ(r.degenerate_triangle_examples.size(), 1u);
  EXPECT_EQ(r.degenerate_triangle_examples[0], 13u);
  EXPECT_EQ(r.min_triangle_area, 0.0);
  // The sliver itself is never part of a pair, but the two triangles on either side of it
  // now touch along half of the split edge without sharing it: two real contacts.
  EXPECT_EQ(r.self_intersecting_pairs, 2u);
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r, "degenerate"));

  // Near-zero relative to the mesh: a sliver 1e-15 of the size, and a repeated index.
  Mesh m = test::box();
  m.positions.push_back({0.5, 1e-15, 0});
  m.triangles.push_back({0, 1, 8});
  m.triangles.push_back({0, 0, 1});
  EXPECT_EQ(check_mesh(m).degenerate_triangles, 2u);
}

TEST(Checks, FinMakesANonManifoldEdge) {
  const MeshCheckReport r = check_mesh(test::box_with_fin());
  EXPECT_FALSE(r.edge_manifold);
  EXPECT_EQ(r.nonmanifold_edges, 1u);
  ASSERT_EQ(r.nonmanifold_edge_examples.size(), 1u);
  EXPECT_EQ(r.nonmanifold_edge_examples[0], (std::array<std::uint32_t, 2>{0, 1}));
  EXPECT_EQ(r.boundary_edges, 2u);
  EXPECT_FALSE(r.oriented);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r, "edge-manifold"));
}

TEST(Checks, TetrahedraSharingAVertexAreNotVertexManifold) {
  const MeshCheckReport r = check_mesh(test::tetrahedra_sharing_vertex());
  EXPECT_TRUE(r.closed);
  EXPECT_TRUE(r.edge_manifold);
  EXPECT_EQ(r.nonmanifold_vertices, 1u);
  EXPECT_EQ(r.nonmanifold_vertex_examples, std::vector<std::uint32_t>{0});
  EXPECT_EQ(r.unreferenced_vertices, 1u);
  EXPECT_EQ(r.components, 1u);
  EXPECT_EQ(r.self_intersecting_pairs, 0u);
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r, "vertex-manifold"));
}

TEST(Checks, InwardFacingMeshHasNegativeVolume) {
  Mesh m = test::icosphere(1);
  for (auto& t : m.triangles) std::swap(t[1], t[2]);
  const MeshCheckReport r = check_mesh(m);
  EXPECT_TRUE(r.oriented);
  EXPECT_LT(r.signed_volume, 0);
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r, "volume"));
}

TEST(Checks, VolumeIsPreciseFarFromTheOrigin) {
  // A 5 mm twig at UTM-like coordinates: the volume is computed about the box centre.
  const Mesh m =
      test::translated(test::capped_tube({0, 0, 0}, {0, 0, 0.1}, 0.005, 16, 4, false), {500000.0, 5000000.0, 254.0});
  const MeshCheckReport r = check_mesh(m);
  const double expected = check_mesh(test::capped_tube({0, 0, 0}, {0, 0, 0.1}, 0.005, 16, 4, false)).signed_volume;
  EXPECT_NEAR(r.signed_volume, expected, 1e-6 * expected);
  EXPECT_TRUE(r.ok()) << to_text(r);
}

TEST(Checks, BadInputsDoNotCrash) {
  Mesh bad = test::box();
  bad.triangles.push_back({0, 1, 99});
  EXPECT_THROW(check_mesh(bad), InvalidInputError);

  const MeshCheckReport empty = check_mesh(Mesh{});
  EXPECT_FALSE(empty.ok());
  EXPECT_TRUE(mentions(empty, "no triangles"));

  Mesh nan = test::box();
  nan.positions[3].x = std::numeric_limits<double>::quiet_NaN();
  const MeshCheckReport rn = check_mesh(nan);
  EXPECT_EQ(rn.nonfinite_vertices, 1u);
  EXPECT_FALSE(rn.self_intersections_checked);
  EXPECT_FALSE(rn.ok());
}

// ---------------------------------------------------------------- fidelity

Skeleton two_node_skeleton(glm::dvec3 a, glm::dvec3 b, double r) {
  RawSkeleton raw;
  raw.add(0, -1, a, r);
  raw.add(1, 0, b, r);
  return test::built(raw);
}

TEST(Checks, FidelityOfAMatchingCylinderIsHigh) {
  const Skeleton skel = two_node_skeleton({0, 0, 0}, {0, 0, 1}, 0.1);
  const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 32, 16, false);
  const MeshCheckReport r = check_mesh(m, {.skeleton = &skel});
  EXPECT_TRUE(r.fidelity_checked);
  EXPECT_LT(r.fidelity_p50, 1e-9);
  EXPECT_LT(r.fidelity_p95, 1e-9);
  EXPECT_NEAR(r.fidelity_max, 1.0, 1e-9);  // the flat caps' centres sit one radius deep
  // Only the caps' centres are beyond the tolerance, and they are the examples.
  EXPECT_EQ(r.fidelity_outliers, 2u);
  ASSERT_EQ(r.fidelity_outlier_examples.size(), 2u);
  for (const std::uint32_t v : r.fidelity_outlier_examples) {
    EXPECT_LT(glm::length(glm::dvec2(m.positions[v])), 1e-12) << v;
  }
  EXPECT_TRUE(r.inside_checked);
  EXPECT_EQ(r.thick_nodes, 2u);
  EXPECT_EQ(r.thick_nodes_inside, 2u);
  EXPECT_TRUE(r.ok()) << to_text(r);
}

TEST(Checks, FidelityOfAScaledCylinderFails) {
  const Skeleton skel = two_node_skeleton({0, 0, 0}, {0, 0, 1}, 0.1);
  const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.15, 32, 16, false);
  const MeshCheckReport r = check_mesh(m, {.skeleton = &skel});
  EXPECT_NEAR(r.fidelity_p50, 0.5, 1e-9);
  EXPECT_NEAR(r.fidelity_p95, 0.5, 1e-9);
  EXPECT_EQ(fidelity_p95(m, skel), r.fidelity_p95);  // (the repair's guard: the same value alone)
  EXPECT_EQ(r.fidelity_outliers, m.positions.size());  // every vertex is half a radius out
  EXPECT_EQ(r.fidelity_outlier_examples.size(), MeshCheckParams{}.max_examples);
  EXPECT_FALSE(r.ok());
  EXPECT_TRUE(mentions(r, "fidelity"));
  // A looser tolerance accepts it.
  EXPECT_TRUE(check_mesh(m, {.skeleton = &skel, .fidelity_tolerance = 0.6}).ok());
}

TEST(Checks, FidelityOfASphereAroundOneNode) {
  RawSkeleton raw;
  raw.add(0, -1, {1, 2, 3}, 0.5);
  const Skeleton skel = test::built(raw);
  const Mesh m = test::icosphere(2, 0.5, {1, 2, 3});
  const MeshCheckReport r = check_mesh(m, {.skeleton = &skel});
  EXPECT_LT(r.fidelity_max, 1e-9);
  EXPECT_EQ(r.thick_nodes_inside, 1u);
  EXPECT_TRUE(r.ok()) << to_text(r);
}

TEST(Checks, NodesInsideOverlappingPartsAreInside) {
  // Two closed boxes through each other: a ray from a node inside both crosses two surfaces,
  // and CGAL's parity test calls it outside; its winding number is 2.
  RawSkeleton raw;
  raw.add(0, -1, {0.25, 0.25, 0.25}, 0.1);  // inside the first box only
  raw.add(1, 0, {0.75, 0.75, 0.75}, 0.1);   // inside both
  raw.add(2, 1, {2.0, 2.0, 2.0}, 0.1);      // outside both
  const Skeleton skel = test::built(raw);
  ASSERT_EQ(skel.size(), 3u);
  const MeshCheckReport r = check_mesh(test::interpenetrating_boxes(), {.skeleton = &skel});
  ASSERT_TRUE(r.inside_checked);
  EXPECT_EQ(r.thick_nodes, 3u);
  EXPECT_EQ(r.thick_nodes_inside, 2u);
  EXPECT_EQ(r.thick_nodes_in_overlaps, 1u);
  ASSERT_EQ(r.outside_node_examples.size(), 1u);
  EXPECT_EQ(skel.position[r.outside_node_examples[0]], dvec3(2.0));
  EXPECT_TRUE(r.self_intersecting_pairs > 0);
}

TEST(Checks, EveryNodeOfALargeSkeletonIsTestedForInside) {
  // 27,000 nodes of equal radius (all thick) on a grid through the two boxes: each one is
  // inside exactly when it lies in a box, and inside both where the boxes overlap (winding
  // number 2). All of them are answered in one pass (a 1,000,000-node chain took over 40 min
  // with one query per node).
  RawSkeleton raw;
  std::size_t expected_inside = 0, expected_overlap = 0;
  auto in_box = [](const dvec3& p, double lo, double hi) {
    return p.x > lo && p.x < hi && p.y > lo && p.y < hi && p.z > lo && p.z < hi;
  };
  for (int i = 0; i < 30; ++i)
    for (int j = 0; j < 30; ++j)
      for (int k = 0; k < 30; ++k) {
        const dvec3 p = dvec3(-0.2) + 0.0637 * dvec3(i, j, k);  // never on a face
        const auto id = static_cast<std::int64_t>(raw.size());
        raw.add(id, id - 1, p, 0.01);
        const bool a = in_box(p, 0, 1), b = in_box(p, 0.5, 1.5);
        expected_inside += a || b;
        expected_overlap += a && b;
      }
  const Skeleton skel = input_skeleton(raw);
  ASSERT_EQ(skel.size(), 27'000u);
  const MeshCheckReport r = check_mesh(test::interpenetrating_boxes(), {.self_intersections = false, .skeleton = &skel});
  ASSERT_TRUE(r.inside_checked);
  EXPECT_EQ(r.thick_nodes, 27'000u);
  EXPECT_GT(expected_overlap, 0u);
  EXPECT_EQ(r.thick_nodes_inside, expected_inside);
  EXPECT_EQ(r.thick_nodes_in_overlaps, expected_overlap);
}

TEST(Checks, FidelityAlongATaperedCone) {
  // Vertices placed on the side of the round cone of a tapered edge: deviation ~0; the same
  // vertices pushed out by 20% of the local radius: deviation ~0.2.
  const double ra = 0.2, rb = 0.1, len = 1.0;
  const Skeleton skel = [&] {
    RawSkeleton raw;
    raw.add(0, -1, {0, 0, 0}, ra);
    raw.add(1, 0, {0, 0, len}, rb);
    return test::built(raw);
  }();
  const double s = (ra - rb) / len, c = std::sqrt(1 - s * s);
  Mesh on, out;
  for (int i = 0; i <= 10; ++i) {
    // Points along the tangent line from a's tangent point to b's, at several angles.
    const double f = (i + 0.5) / 11.0;  // inside the conical part, away from the end spheres
    const double y = ra * s + f * (len * 1.0 + rb * s - ra * s);
    const double x = ra * c + f * (rb * c - ra * c);
    const double local = ra + (y / len) * (rb - ra);
    for (int k = 0; k < 4; ++k) {
      const double th = k * 1.5707963267948966;
      on.positions.push_back({x * std::cos(th), x * std::sin(th), y});
      const double push = 0.2 * local;
      out.positions.push_back({(x + push * c) * std::cos(th), (x + push * c) * std::sin(th), y + push * s});
    }
  }
  for (std::uint32_t i = 0; i + 2 < on.positions.size(); ++i) {
    on.triangles.push_back({i, i + 1, i + 2});
    out.triangles.push_back({i, i + 1, i + 2});
  }
  EXPECT_LT(check_mesh(on, {.self_intersections = false, .skeleton = &skel}).fidelity_max, 1e-9);
  const MeshCheckReport r = check_mesh(out, {.self_intersections = false, .skeleton = &skel});
  EXPECT_NEAR(r.fidelity_p50, 0.2, 1e-6);
  EXPECT_NEAR(r.fidelity_max, 0.2, 1e-6);
}

TEST(Checks, ThickNodesOutsideTheMeshFail) {
  // A skeleton longer than the mesh: its nodes beyond the mesh are reported.
  RawSkeleton raw;
  raw.add(0, -1, {0, 0, 0}, 0.1);
  raw.add(1, 0, {0, 0, 1}, 0.1);
  raw.add(2, 1, {0, 0, 2}, 0.1);
  const Skeleton skel = test::built(raw);
  const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 32, 16, false);
  const MeshCheckReport r = check_mesh(m, {.skeleton = &skel, .fidelity_tolerance = 100});
  EXPECT_EQ(r.thick_nodes, 3u);
  EXPECT_EQ(r.thick_nodes_inside, 2u);
  EXPECT_TRUE(mentions(r, "outside the mesh"));
}

TEST(Checks, TextAndJsonReports) {
  const MeshCheckReport good = check_mesh(test::icosphere(1));
  const std::string text = to_text(good);
  EXPECT_NE(text.find("result: ok"), std::string::npos) << text;
  EXPECT_NE(text.find("genus"), std::string::npos);
  const nlohmann::json j = to_json(good);
  EXPECT_TRUE(j["ok"].get<bool>());
  EXPECT_EQ(j["triangles"].get<std::size_t>(), 80u);
  EXPECT_EQ(j["genus"].get<int>(), 0);
  EXPECT_TRUE(j["failures"].empty());

  const MeshCheckReport bad = check_mesh(test::box_with_missing_triangle());
  EXPECT_NE(to_text(bad).find("result: FAILED"), std::string::npos);
  EXPECT_NE(to_text(bad).find("problem: 3 boundary edges"), std::string::npos);
  const nlohmann::json jb = to_json(bad);
  EXPECT_FALSE(jb["ok"].get<bool>());
  EXPECT_TRUE(jb["genus"].is_null());
  EXPECT_EQ(jb["examples"]["boundary_edges"].size(), 3u);
}

// ---------------------------------------------------------------- strandmesh check

using test::CmdResult;
// ---- the genus a skeleton implies (meshcheck/implied_genus.h)

ImpliedGenus implied(const RawSkeleton& raw, const ImpliedGenusParams& params = {}) {
  return implied_genus(input_skeleton(raw), params);
}

/// A chain of `nodes` nodes along a gentle helix, `step` apart, of radius `radius`.
RawSkeleton chain(int nodes, double step, double radius) {
  RawSkeleton raw;
  for (int i = 0; i < nodes; ++i) {
    const double t = 0.01 * i;
    raw.add(i, i - 1, dvec3(0.2 * std::cos(t), 0.2 * std::sin(t), step * i), radius);
  }
  return raw;
}

TEST(ImpliedGenus, ChainsAndForksHaveNone) {
  EXPECT_EQ(implied(test::straight_branch()).genus, 0);
  EXPECT_EQ(implied(test::y_fork()).genus, 0);
  EXPECT_EQ(implied(test::trifurcation()).genus, 0);
  EXPECT_EQ(implied(test::zero_length_edges()).genus, 0);
  // Steps of half a radius: every cone meets its neighbours up to five edges on (crossing
  // pairs without a shared node), all of them filled in by the cones between.
  const ImpliedGenus dense = implied(chain(5000, 0.01, 0.02));
  EXPECT_EQ(dense.genus, 0);
  EXPECT_EQ(dense.genus_min, 0);
  EXPECT_GT(dense.crossing_pairs, 3u * 4990u);
  // A lone node, one edge: nothing to cross.
  RawSkeleton one;
  one.add(0, -1, dvec3(0), 0.1);
  EXPECT_EQ(implied(one).genus, 0);
  one.add(1, 0, dvec3(0, 0, 1), 0.1);
  EXPECT_EQ(implied(one).cones, 1u);
  EXPECT_EQ(implied(one).genus, 0);
}

TEST(ImpliedGenus, LateralsCrossingAwayFromTheirForksMakeAHandle) {
  const ImpliedGenus g = implied(test::crossing_laterals());
  EXPECT_EQ(g.genus, 1);
  EXPECT_TRUE(g.exact());
  // Located at the crossing: a pair of the laterals' nodes 4-5 and 6-7.
  ASSERT_EQ(g.handle_examples.size(), 1u);
  EXPECT_TRUE(g.handle_examples[0][0] == 4 || g.handle_examples[0][0] == 5) << g.handle_examples[0][0];
  EXPECT_TRUE(g.handle_examples[0][1] == 6 || g.handle_examples[0][1] == 7) << g.handle_examples[0][1];
  EXPECT_GE(g.crossing_pairs, 2u);  // the laterals' edges at the crossing
  EXPECT_EQ(g.robust_genus, 1);  // 0.05 m between axes, radii 0.035: deep
  // Barely touching (axes 0.0699 m apart): a handle, but not a robust one (gone with radii
  // 10 % smaller).
  RawSkeleton touching = test::crossing_laterals();
  touching.position[6].y = touching.position[7].y = 0.0699;
  const ImpliedGenus t = implied(touching, {.robust_margin = 0.1});
  EXPECT_EQ(t.genus, 1);
  EXPECT_EQ(t.robust_genus, 0);
  // Moved apart (0.1 m between the laterals' axes, radii 0.035): no crossing, no handle.
  RawSkeleton apart = test::crossing_laterals();
  apart.position[6].y = apart.position[7].y = 0.1;
  const ImpliedGenus a = implied(apart);
  EXPECT_EQ(a.crossing_pairs, 0u);
  EXPECT_EQ(a.genus, 0);
}

TEST(ImpliedGenus, HubOfTwigsHasNone) {
  // Every twig holds the hub node's centre: one filled simplex, however many (the cliques are
  // never listed, so 5,000 twigs cost no more than a chain of 5,000).
  EXPECT_EQ(implied(test::star(20)).genus, 0);
  const ImpliedGenus big = implied(test::star(5000));
  EXPECT_EQ(big.genus, 0);
  EXPECT_EQ(big.crossing_pairs, 0u);
  EXPECT_EQ(big.triangles_tested, 0u);
}

TEST(ImpliedGenus, BranchTouchingItsParentOnlyAtTheForkHasNone) {
  // A 12-degree lateral fused with the trunk for a long way, and a second lateral inside that
  // fused section: their cones overlap the trunk's away from the shared node, but the overlap
  // reaches back to the fork.
  const ImpliedGenus g = implied(test::lateral_inside_fused_section());
  EXPECT_GT(g.crossing_pairs, 0u);
  EXPECT_EQ(g.genus, 0);
  EXPECT_TRUE(g.exact());
}

TEST(ImpliedGenus, BranchBendingBackOntoItsParentMakesAHandle) {
  // A lateral from z = 1 that turns back and touches the trunk again at z = 2.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0, 0, 0), 0.08);
  raw.add(1, 0, dvec3(0, 0, 1.0), 0.07);
  raw.add(2, 1, dvec3(0, 0, 2.0), 0.06);
  raw.add(3, 2, dvec3(0, 0, 3.0), 0.05);
  raw.add(4, 1, dvec3(0.5, 0, 1.5), 0.035);
  raw.add(5, 4, dvec3(0.07, 0, 2.0), 0.03);
  EXPECT_EQ(implied(raw).genus, 1);
  raw.position[5].x = 0.2;  // stops short of it
  EXPECT_EQ(implied(raw).genus, 0);
}

TEST(ImpliedGenus, RingOfTwoCrossingsHasTwoHandles) {
  // Lateral B from z = 2 crosses lateral A from z = 1 twice, swinging away in between: the
  // loop through the trunk and the ring between the crossings.
  RawSkeleton raw;
  raw.add(0, -1, dvec3(0, 0, 0), 0.08);
  raw.add(1, 0, dvec3(0, 0, 1), 0.07);
  raw.add(2, 1, dvec3(0, 0, 2), 0.06);
  raw.add(3, 2, dvec3(0, 0, 3), 0.05);
  raw.add(10, 1, dvec3(0.4, 0, 1.5), 0.03);
  raw.add(11, 10, dvec3(0.8, 0, 1.5), 0.03);
  raw.add(12, 11, dvec3(1.2, 0, 1.5), 0.03);
  raw.add(13, 12, dvec3(1.6, 0, 1.5), 0.03);
  raw.add(20, 2, dvec3(0.4, 0.04, 1.5), 0.03);
  raw.add(21, 20, dvec3(0.8, 0.4, 1.5), 0.03);
  raw.add(22, 21, dvec3(1.2, -0.04, 1.5), 0.03);
  raw.add(23, 22, dvec3(1.6, -0.4, 1.5), 0.03);
  const ImpliedGenus g = implied(raw);
  EXPECT_EQ(g.genus, 2);
  EXPECT_TRUE(g.exact());
  EXPECT_EQ(g.robust_genus, 2);
  EXPECT_EQ(g.handle_examples.size(), 2u);
  // Without the second crossing, one.
  raw.position[10].y = 0.5;  // nodes 22 and 23
  raw.position[11].y = 0.2;
  EXPECT_EQ(implied(raw).genus, 1);
}

TEST(ImpliedGenus, CoilOfTouchingTurnsIsOneHandle) {
  // A helix whose turns (pitch 3 cm, radius 2 cm) fuse into one wall: a hollow cylinder,
  // genus 1 however many turns, and 0 once the turns no longer touch.
  auto coil = [](double pitch) {
    RawSkeleton raw;
    for (int i = 0; i <= 5 * 40; ++i) {
      const double a = 2 * std::numbers::pi * i / 40.0;
      raw.add(i, i - 1, dvec3(0.2 * std::cos(a), 0.2 * std::sin(a), pitch * i / 40.0), 0.02);
    }
    return raw;
  };
  const ImpliedGenus g = implied(coil(0.03));
  EXPECT_EQ(g.genus, 1);
  EXPECT_EQ(g.robust_genus, 1);
  EXPECT_TRUE(g.exact());
  EXPECT_EQ(implied(coil(0.05)).genus, 0);
}

TEST(ImpliedGenus, SearchCapGivesARange) {
  // With no iterative searches allowed, triangles without a cheap witness stay undecided: the
  // result is a range that holds the answer.
  const ImpliedGenus g = implied(test::crossing_laterals(), {.max_searches = 0});
  EXPECT_GT(g.undecided, 0u);
  EXPECT_FALSE(g.exact());
  EXPECT_LE(g.genus_min, 1);
  EXPECT_GE(g.genus, 1);
  // Fewer triangle candidates listed than there are: the range starts at 0.
  const ImpliedGenus listed = implied(test::crossing_laterals(), {.max_listed = 0});
  EXPECT_EQ(listed.genus_min, 0);
  EXPECT_GE(listed.genus, 1);
  // More candidate pairs than allowed: no figure, and `check` leaves it out.
  const ImpliedGenus tangle = implied(test::crossing_laterals(), {.max_candidates = 1});
  EXPECT_FALSE(tangle.complete);
  EXPECT_EQ(tangle.genus, 0);
}

TEST(ImpliedGenus, ReportedBesideTheMeshGenus) {
  // A torus checked against the crossing laterals: both of genus 1, they agree.
  const Skeleton skel = input_skeleton(test::crossing_laterals());
  const MeshCheckReport r =
      check_mesh(test::torus(), {.self_intersections = false, .skeleton = &skel, .implied_genus = true});
  ASSERT_TRUE(r.implied_genus_checked);
  EXPECT_EQ(r.implied_genus, 1);
  EXPECT_EQ(r.genus_agrees(), std::optional<bool>(true));
  EXPECT_NE(to_text(r).find("implied genus         1 ("), std::string::npos) << to_text(r);
  EXPECT_NE(to_text(r).find("handles e.g. at nodes "), std::string::npos) << to_text(r);
  EXPECT_NE(to_text(r).find("mesh vs implied     agree"), std::string::npos) << to_text(r);
  EXPECT_EQ(r.implied_genus_robust, 1);
  const nlohmann::json j = to_json(r);
  EXPECT_EQ(j["implied_genus"].get<int>(), 1);
  EXPECT_EQ(j["implied_genus_robust"].get<int>(), 1);
  EXPECT_TRUE(j["genus_agrees"].get<bool>());
  // Informative: a mismatch is no failure.
  const MeshCheckReport sphere =
      check_mesh(test::icosphere(2), {.self_intersections = false, .skeleton = &skel, .implied_genus = true});
  EXPECT_EQ(sphere.genus_agrees(), std::optional<bool>(false));
  EXPECT_FALSE(mentions(sphere, "genus"));
  EXPECT_NE(to_text(sphere).find("a crossing's handle is missing"), std::string::npos) << to_text(sphere);
  // Not asked for: not computed.
  EXPECT_FALSE(check_mesh(test::torus(), {.self_intersections = false, .skeleton = &skel}).implied_genus_checked);
}

CmdResult run(const std::string& args) { return test::run_cli(args); }

TEST(CheckCli, ExitCodes) {
  const fs::path dir = test::temp_dir("check_cli");
  write_mesh(test::capped_tube(), dir / "tube.glb");
  write_mesh(test::torus(), dir / "torus.ply");
  write_file_atomically(dir / "garbage.obj", "v 1 2\n");

  const CmdResult ok = run("check " + (dir / "tube.glb").string());
  EXPECT_EQ(ok.code, 0) << ok.out << ok.err;
  EXPECT_NE(ok.out.find("result: ok"), std::string::npos);

  // A handle is no failure (crossing branches fused); two parts are.
  const CmdResult torus = run("check " + (dir / "torus.ply").string());
  EXPECT_EQ(torus.code, 0) << torus.out << torus.err;
  EXPECT_NE(torus.out.find("1 (handles where branches cross and fuse)"), std::string::npos) << torus.out;
  write_mesh(test::two_spheres(), dir / "two.ply");
  const CmdResult two = run("check " + (dir / "two.ply").string());
  EXPECT_EQ(two.code, 4) << two.out << two.err;
  EXPECT_NE(two.out.find("2 connected components"), std::string::npos);

  const CmdResult garbage = run("check " + (dir / "garbage.obj").string());
  EXPECT_EQ(garbage.code, 1);
  EXPECT_NE(garbage.err.find("garbage.obj:1"), std::string::npos) << garbage.err;

  EXPECT_EQ(run("check " + (dir / "missing.glb").string()).code, 1);
  EXPECT_EQ(run("check " + (dir / "tube.stl").string()).code, 1);
  EXPECT_EQ(run("check").code, 2);
}

TEST(CheckCli, JsonAndSkeleton) {
  const fs::path dir = test::temp_dir("check_cli_json");
  const Skeleton skel = two_node_skeleton({0, 0, 0}, {0, 0, 1}, 0.1);
  write_skeleton_json(skel, dir / "skel.json");
  write_mesh(test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 32, 16), dir / "tube.glb", {.up_axis = skel.up_axis});
  write_mesh(test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.2, 32, 16), dir / "fat.glb", {.up_axis = skel.up_axis});

  const CmdResult r =
      run("check --json --skeleton " + (dir / "skel.json").string() + " " + (dir / "tube.glb").string());
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_TRUE(j["ok"].get<bool>());
  EXPECT_TRUE(j["fidelity_checked"].get<bool>());
  EXPECT_LT(j["fidelity"]["p95"].get<double>(), 1e-3);  // float32 storage, read back z-up
  EXPECT_EQ(j["thick_nodes_inside"].get<int>(), 2);
  EXPECT_EQ(j["implied_genus"].get<int>(), 0);  // with --skeleton, beside the mesh's
  EXPECT_TRUE(j["genus_agrees"].get<bool>());

  const CmdResult fat = run("check --skeleton " + (dir / "skel.json").string() + " " + (dir / "fat.glb").string());
  EXPECT_EQ(fat.code, 4);
  EXPECT_NE(fat.out.find("fidelity p95"), std::string::npos) << fat.out;

  const CmdResult quick = run("check --json --no-self-intersections " + (dir / "tube.glb").string());
  ASSERT_EQ(quick.code, 0) << quick.err;
  EXPECT_FALSE(nlohmann::json::parse(quick.out)["self_intersections_checked"].get<bool>());
}

TEST(Checks, UnpairedHalfEdgesCountWhatMeshingWarnsOf) {
  // The meshing stage's own topology check (MeshStats::bad_edges): every half-edge needs
  // exactly one twin and may occur only once.
  auto unpaired = [](const Mesh& m) { return unpaired_half_edges(m, vertex_corners(m)); };
  EXPECT_EQ(unpaired(test::box()), 0u);
  EXPECT_EQ(unpaired(test::icosphere(3)), 0u);
  EXPECT_EQ(unpaired(test::torus()), 0u);  // closed and oriented, whatever the genus
  // The hole's three edges, each seen once, from the side still there.
  EXPECT_EQ(unpaired(test::box_with_missing_triangle()), 3u);
  // Each of the flipped triangle's edges runs the same way as its neighbour's: both copies count.
  EXPECT_EQ(unpaired(test::box_with_flipped_triangle()), 6u);
  // The fin: its free edges and the shared edge, seen three times, are all unpaired.
  EXPECT_GT(unpaired(test::box_with_fin()), 0u);
  // A vertex of high degree (the apex of a 100-sided cone: more corners than fit on the stack).
  Mesh cone;
  const int n = 100;
  cone.positions.push_back({0, 0, 1});
  cone.positions.push_back({0, 0, 0});
  for (int k = 0; k < n; ++k) cone.positions.push_back({std::cos(2 * M_PI * k / n), std::sin(2 * M_PI * k / n), 0});
  for (std::uint32_t k = 0; k < std::uint32_t(n); ++k) {
    const std::uint32_t a = 2 + k, b = 2 + (k + 1) % n;
    cone.triangles.push_back({0, a, b});
    cone.triangles.push_back({1, b, a});
  }
  EXPECT_EQ(unpaired(cone), 0u);
  cone.triangles.pop_back();
  EXPECT_EQ(unpaired(cone), 3u);
}

// ---------------------------------------------------------------- triangle quality

/// One isosceles triangle per apex angle (degrees), legs of 1 m, none sharing an edge.
Mesh isosceles_triangles(const std::vector<double>& apex_degrees) {
  Mesh m;
  double x = 0;
  for (const double deg : apex_degrees) {
    const double h = deg * std::numbers::pi / 360.0;  // half the apex angle
    const auto v = static_cast<std::uint32_t>(m.positions.size());
    m.positions.push_back({x, 0, 0});
    m.positions.push_back({x + std::cos(h), -std::sin(h), 0});
    m.positions.push_back({x + std::cos(h), std::sin(h), 0});
    m.triangles.push_back({v, v + 1, v + 2});
    x += 2;
  }
  return m;
}

TEST(Quality, BoxAnglesAspectRatiosAndDihedralAngles) {
  const TriangleQuality q = measure_quality(test::box());
  EXPECT_EQ(q.triangles, 12u);
  EXPECT_EQ(q.under_10, 0u);
  EXPECT_NEAR(q.min_angle, 45.0, 1e-9);
  // Right isosceles triangles: sqrt(3) against 1 for an equilateral one.
  EXPECT_NEAR(q.aspect_p95, std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(q.aspect_max, std::sqrt(3.0), 1e-12);
  // 12 edges at 90 degrees, 6 face diagonals at 0: p99 and max 90.
  EXPECT_FALSE(q.caps_known);
  EXPECT_EQ(q.edges, 18u);
  EXPECT_NEAR(q.dihedral_max, 90.0, 1e-9);
  EXPECT_NEAR(q.dihedral_p99, 90.0, 1e-9);
  ASSERT_EQ(q.sharpest_edges.size(), 5u);
  EXPECT_TRUE(q.normals_computed);
  EXPECT_EQ(q.backward_normals, 0u);
}

TEST(Quality, SmallAnglesAreCountedPerThreshold) {
  const TriangleQuality q = measure_quality(isosceles_triangles({0.5, 3, 7, 20, 60}));
  EXPECT_EQ(q.triangles, 5u);
  EXPECT_EQ(q.under_1, 1u);
  EXPECT_EQ(q.under_5, 2u);
  EXPECT_EQ(q.under_10, 3u);
  EXPECT_NEAR(q.share_under_10(), 0.6, 1e-12);
  EXPECT_NEAR(q.min_angle, 0.5, 1e-9);
  // Aspect ratio sqrt(3) / (2 sin apex) for legs longer than the base; the p95 of five is the largest.
  EXPECT_NEAR(q.aspect_max, std::sqrt(3.0) / (2 * std::sin(0.5 * std::numbers::pi / 180)), 1e-6);
  EXPECT_NEAR(q.aspect_p95, q.aspect_max, 1e-12);
  EXPECT_EQ(q.edges, 0u);  // no edge has two triangles
}

TEST(Quality, CapsAreLeftOutAndJunctionsMeasured) {
  // 16 segments: neighbouring side faces meet at 22.5 degrees, the flat caps at 90 degrees.
  const Mesh tube = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 16, 8, false);
  const TriangleQuality plain = measure_quality(tube);
  EXPECT_EQ(plain.edges, 368u + 64u);
  EXPECT_NEAR(plain.dihedral_max, 90.0, 1e-9);

  const Skeleton line = two_node_skeleton({0, 0, 0}, {0, 0, 1}, 0.1);
  const TriangleQuality q = measure_quality(tube, &line);
  EXPECT_TRUE(q.caps_known);
  EXPECT_EQ(q.cap_edges, 64u);  // spokes and rims of both caps
  EXPECT_EQ(q.edges, 368u);     // 128 vertical edges at 22.5 degrees, 240 flat ones
  EXPECT_NEAR(q.dihedral_max, 22.5, 1e-9);
  EXPECT_NEAR(q.dihedral_p99, 22.5, 1e-9);
  EXPECT_EQ(q.junction_edges, 0u);

  // A fork at mid-height (a lateral leaving the tube): edges with their midpoint within
  // 3 radii (0.3 m) of it are junction edges: 4 rows of vertical edges and diagonals, 5 rings.
  RawSkeleton raw;
  raw.add(0, -1, {0, 0, 0}, 0.1);
  raw.add(1, 0, {0, 0, 0.5}, 0.1);
  raw.add(2, 1, {0, 0, 1}, 0.1);
  raw.add(3, 1, {0.4, 0, 0.7}, 0.03);
  const Skeleton fork = test::built(raw);
  ASSERT_TRUE(fork.is_fork(NodeId(1u))) << fork.size() << " nodes";
  const TriangleQuality f = measure_quality(tube, &fork);
  EXPECT_EQ(f.junction_edges, 4u * 16 + 4u * 16 + 5u * 16);
  EXPECT_NEAR(f.junction_dihedral_max, 22.5, 1e-9);
  EXPECT_NEAR(f.junction_dihedral_p99, 22.5, 1e-9);
}

TEST(Quality, BackwardNormalsAreCounted) {
  Mesh m = test::box();
  m.normals = angle_weighted_normals(m);
  EXPECT_EQ(measure_quality(m).backward_normals, 0u);
  m.normals[3] = -m.normals[3];
  const TriangleQuality q = measure_quality(m);
  EXPECT_FALSE(q.normals_computed);
  EXPECT_EQ(q.backward_normals, 1u);
  EXPECT_EQ(q.backward_normal_examples, std::vector<std::uint32_t>{3});
}

TEST(Quality, BackwardNormalsAreCountedPerCornerWithSmoothingGroups) {
  // A 4-degree wedge: its vertex normals are nearly 90 degrees from the long sides, and turned
  // around at vertex 2 they face away. With corner normals (smoothing groups) the check
  // measures those instead, as a renderer shades them: each side's own normal, none backward.
  Mesh m = test::wedge(4.0);
  m.normals = angle_weighted_normals(m);
  m.normals[2] = -m.normals[2];
  EXPECT_EQ(measure_quality(m).backward_normals, 1u);
  m.corner_normals = split_vertex_normals(m, vertex_corners(m), angle_weighted_normals(m), 90.0).corner_normals;
  ASSERT_EQ(m.corner_normals.size(), m.triangles.size());
  const TriangleQuality q = measure_quality(m);
  EXPECT_TRUE(q.normals_per_corner);
  EXPECT_EQ(q.backward_normals, 0u);
  // One corner turned around: its vertex counts, once.
  m.corner_normals[4][2] = -m.corner_normals[4][2];  // triangle (1, 2, 5), corner at vertex 5
  const TriangleQuality back = measure_quality(m);
  EXPECT_EQ(back.backward_normals, 1u);
  EXPECT_EQ(back.backward_normal_examples, std::vector<std::uint32_t>{5});
}

TEST(Quality, LimitsFailAndReportsShowTheFigures) {
  // One ring of 64 segments along 1 m: every side triangle a needle under 1 degree, the cap
  // fans 5.6 degrees at the centre.
  const Mesh needles = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 64, 1, false);
  const MeshCheckReport informative = check_mesh(needles, {.self_intersections = false});
  EXPECT_TRUE(informative.quality_checked);
  EXPECT_TRUE(informative.ok()) << to_text(informative);
  EXPECT_EQ(informative.quality.under_1, 128u);
  EXPECT_EQ(informative.quality.under_10, 256u);

  const MeshCheckReport held = check_mesh(needles, {.self_intersections = false, .quality_limits = QualityLimits{}});
  EXPECT_FALSE(held.ok());
  EXPECT_TRUE(mentions(held, "100 % of the triangles have an angle under 10 degrees (limit 2 %)")) << to_text(held);
  EXPECT_TRUE(mentions(held, "128 triangles have an angle under 1 degree (limit 0)")) << to_text(held);
  const std::string text = to_text(held);
  EXPECT_NE(text.find("small angles          100 % of the triangles under 10 degrees"), std::string::npos) << text;
  const nlohmann::json j = to_json(held);
  EXPECT_EQ(j["quality"]["under_1"].get<std::size_t>(), 128u);
  EXPECT_DOUBLE_EQ(j["quality"]["share_under_10"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(j["quality"]["limits"]["max_share_under_10"].get<double>(), 0.02);

  EXPECT_TRUE(check_mesh(test::box(), {.quality_limits = QualityLimits{}}).ok());
}

TEST(CheckCli, QualityLimits) {
  const fs::path dir = test::temp_dir("check_cli_quality");
  write_mesh(test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 64, 1, false), dir / "needles.glb");
  const CmdResult plain = run("check --json " + (dir / "needles.glb").string());
  ASSERT_EQ(plain.code, 0) << plain.out << plain.err;
  const nlohmann::json j = nlohmann::json::parse(plain.out);
  EXPECT_EQ(j["quality"]["under_1"].get<std::size_t>(), 128u);
  EXPECT_EQ(j["quality"]["backward_normals"].get<std::size_t>(), 0u);
  const CmdResult held = run("check --quality-limits " + (dir / "needles.glb").string());
  EXPECT_EQ(held.code, 4) << held.out << held.err;
  EXPECT_NE(held.out.find("under 1 degree"), std::string::npos) << held.out;
}

}  // namespace
}  // namespace sm

namespace sm {
namespace {

// A tube with u = j / 16 once around (a seam where u wraps) and v the height, planar caps:
// every figure of the UV quality is known.
TEST(UvQuality, TubeSeamsAndStretch) {
  const Mesh tube = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 16, 8, true);
  // The side's map: u grows by 1/16 over a chord of 2 r sin(pi / 16), v by 1 per metre.
  const double su = (1.0 / 16) / (2 * 0.1 * std::sin(std::numbers::pi / 16));

  const UvQuality plain = measure_uv_quality(tube);
  EXPECT_FALSE(plain.caps_known);
  EXPECT_EQ(plain.seam_edges, 8u + 32u);
  EXPECT_EQ(plain.around_seams, 8u);  // one per ring of quads
  EXPECT_EQ(plain.other_seams, 32u);  // the rims, where the caps' planar UVs meet the side's
  EXPECT_EQ(plain.triangles, 256u + 32u);
  EXPECT_EQ(plain.flipped, 16u);  // one cap is mirrored against the side (planar UVs seen from inside)

  const Skeleton line = two_node_skeleton({0, 0, 0}, {0, 0, 1}, 0.1);
  const UvQuality q = measure_uv_quality(tube, &line);
  EXPECT_TRUE(q.caps_known);
  EXPECT_EQ(q.around_seams, 8u);  // a jump of one turn: 1 over the density is 1.26 circumferences
  EXPECT_EQ(q.other_seams, 32u);
  EXPECT_EQ(q.triangles, 256u);  // the caps left out
  EXPECT_EQ(q.flipped, 0u);
  EXPECT_EQ(q.collapsed, 0u);
  EXPECT_NEAR(q.anisotropy_p95, su, 1e-5 * su);
  EXPECT_NEAR(q.anisotropy_max, su, 1e-5 * su);
  EXPECT_NEAR(q.density_median, std::sqrt(su), 1e-5);
  EXPECT_NEAR(q.density_p95, 1.0, 1e-5);
  EXPECT_EQ(q.junction_triangles, 0u);

  // Once around a tube of circumference 1 m the texels are square (but for the chords).
  const double r1 = 0.5 / std::numbers::pi;
  const Skeleton line1 = two_node_skeleton({0, 0, 0}, {0, 0, 1}, r1);
  const UvQuality round = measure_uv_quality(test::capped_tube({0, 0, 0}, {0, 0, 1}, r1, 64, 8, true), &line1);
  EXPECT_NEAR(round.anisotropy_p95, 1.0, 1e-3);
  EXPECT_EQ(round.around_seams, 8u);
}

TEST(UvQuality, JumpsInVAndMirroredTrianglesAreCounted) {
  Mesh tube = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 16, 8, true);
  const Skeleton line = two_node_skeleton({0, 0, 0}, {0, 0, 1}, 0.1);
  // v shifted by half a unit on the upper four rows of quads: a ring seam of 16 edges.
  for (std::size_t f = 0; f < 256; ++f) {
    if (f / 32 >= 4) {
      for (auto& uv : tube.corner_uvs[f]) uv.y += 0.5f;
    }
  }
  const UvQuality ring = measure_uv_quality(tube, &line);
  EXPECT_EQ(ring.around_seams, 8u);
  EXPECT_EQ(ring.other_seams, 32u + 16u);
  EXPECT_EQ(ring.flipped, 0u);
  // One triangle mirrored in UV (two corners swapped): flipped, and its three edges seams.
  std::swap(tube.corner_uvs[40][1], tube.corner_uvs[40][2]);
  const UvQuality mirrored = measure_uv_quality(tube, &line);
  EXPECT_EQ(mirrored.flipped, 1u);
  EXPECT_GT(mirrored.other_seams, ring.other_seams);

  // Reported by check_mesh, in text and JSON; a mesh without UVs gets no figures.
  const MeshCheckReport report = check_mesh(tube, {.self_intersections = false, .skeleton = &line});
  EXPECT_TRUE(report.uv_checked);
  const std::string text = to_text(report);
  EXPECT_NE(text.find("uv seams"), std::string::npos) << text;
  EXPECT_NE(text.find("uv stretch"), std::string::npos) << text;
  EXPECT_EQ(to_json(report)["uv"]["flipped"].get<std::size_t>(), 1u);
  tube.corner_uvs.clear();
  EXPECT_FALSE(check_mesh(tube, {.self_intersections = false}).uv_checked);
}

}  // namespace
}  // namespace sm
