// Meshing stage: build_mesh called directly on the contours of skeletons built in code
// (tests/fixtures.h), after the real particle, strand and contour stages.

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "meshcheck/checks.h"
#include "meshing/meshing.h"
#include "tests/fixtures.h"
#include "tests/stage_fixtures.h"

namespace sm {
namespace {

struct Built {
  test::UpToContours up;
  MeshResult mesh;
};

Built mesh_of(const RawSkeleton& raw, std::uint64_t seed = 1, const ContourParams& params = {}) {
  Built b{test::up_to_contours(raw, seed, params), {}};
  b.mesh = build_mesh(b.up.skeleton, b.up.contours);
  return b;
}

/// A closed, oriented 2-manifold of genus 0 facing outwards, in one piece, with no degenerate
/// or crossing triangles and every thick skeleton node inside; F = 2V - 4 (Euler).
void expect_sound(const Built& b) {
  const Mesh& m = b.mesh.mesh;
  MeshCheckParams cp;
  cp.skeleton = &b.up.skeleton;
  const MeshCheckReport rep = check_mesh(m, cp);
  EXPECT_TRUE(rep.closed) << rep.boundary_edges << " boundary edges";
  EXPECT_TRUE(rep.edge_manifold);
  EXPECT_TRUE(rep.vertex_manifold);
  EXPECT_TRUE(rep.oriented);
  EXPECT_EQ(rep.components, 1u);
  EXPECT_EQ(rep.genus, 0);
  EXPECT_EQ(rep.unreferenced_vertices, 0u);
  EXPECT_EQ(rep.nonfinite_vertices, 0u);
  EXPECT_EQ(rep.degenerate_triangles, 0u);
  EXPECT_EQ(rep.self_intersecting_pairs, 0u);
  EXPECT_GT(rep.signed_volume, 0);
  EXPECT_EQ(rep.thick_nodes_inside, rep.thick_nodes);
  EXPECT_EQ(m.triangle_count(), 2 * m.vertex_count() - 4);
  EXPECT_EQ(b.mesh.stats.bad_edges, 0u);
  EXPECT_EQ(b.mesh.triangle_kind.size(), m.triangle_count());
  EXPECT_EQ(m.normals.size(), m.vertex_count());
  EXPECT_EQ(m.corner_uvs.size(), m.triangle_count());
}

/// Where no repair touched the mesh, it is exactly the stitching of its contours: the loop
/// vertices first (on the float grid), then a ring and an apex per tip, then the base's
/// centre; a strip has as many triangles as its two loops have vertices, a junction's pants
/// its three loops' vertices plus 2, a tip's dome three per vertex of its loop, the base one
/// per vertex of the root's loop.
void expect_stitched_exactly(const Built& b) {
  const ContourSet& c = b.up.contours;
  const Mesh& m = b.mesh.mesh;
  std::size_t strips = 0, fusion = 0, tip = 0, tip_vertices = 0;
  for (const Tube& t : c.tubes) {
    for (std::size_t k = 0; k + 1 < t.loops.size(); ++k) strips += c.loop_size(t.loops[k]) + c.loop_size(t.loops[k + 1]);
    if (t.end_junction == UINT32_MAX) {
      tip += 3 * c.loop_size(t.loops.back());
      tip_vertices += c.loop_size(t.loops.back()) + 1;
    }
  }
  for (const Junction& j : c.junctions) fusion += c.loop_size(j.lower) + c.loop_size(j.upper[0]) + c.loop_size(j.upper[1]) + 2;
  std::size_t kind[4] = {0, 0, 0, 0};
  for (const TriangleKind k : b.mesh.triangle_kind) ++kind[static_cast<int>(k)];
  EXPECT_EQ(kind[static_cast<int>(TriangleKind::strip)], strips);
  EXPECT_EQ(kind[static_cast<int>(TriangleKind::fusion)], fusion);
  EXPECT_EQ(kind[static_cast<int>(TriangleKind::tip_cap)], tip);
  EXPECT_EQ(kind[static_cast<int>(TriangleKind::root_cap)], c.loop_size(0));
  ASSERT_EQ(m.vertex_count(), c.point.size() + tip_vertices + 1);
  ASSERT_GT(b.mesh.grid, 0);
  for (std::size_t v = 0; v < c.point.size(); ++v) {
    EXPECT_LE(glm::length(m.positions[v] - c.point[v]), b.mesh.grid) << "vertex " << v;
    EXPECT_EQ(m.vertex_strand[v], c.strand[v]) << "vertex " << v;
  }
  EXPECT_EQ(b.mesh.stats.junctions, c.junctions.size());
  EXPECT_EQ(b.mesh.stats.merged_junctions, 0u);
}

TEST(BuildMesh, StraightBranchIsAClosedTubeFacingOutwards) {
  for (const std::uint64_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE("particle seed " + std::to_string(seed));
    const Built b = mesh_of(test::straight_branch(6), seed);
    expect_sound(b);
    expect_stitched_exactly(b);
    EXPECT_EQ(b.mesh.stats.tip_caps, 1u);
    EXPECT_EQ(b.mesh.stats.strips, b.up.contours.loop_count() - 1);
    // The branch runs up the z axis from 0 to 2 m: strips face away from the axis, the base
    // faces down, the dome up and out from the tip loop's centre.
    const Mesh& m = b.mesh.mesh;
    for (std::size_t f = 0; f < m.triangle_count(); ++f) {
      const auto& t = m.triangles[f];
      const glm::dvec3 n = m.face_normal(t), c = (m.positions[t[0]] + m.positions[t[1]] + m.positions[t[2]]) / 3.0;
      switch (b.mesh.triangle_kind[f]) {
        case TriangleKind::strip: EXPECT_GT(glm::dot(n, glm::dvec3(c.x, c.y, 0)), 0) << "triangle " << f; break;
        case TriangleKind::root_cap: EXPECT_LT(n.z, 0) << "triangle " << f; break;
        case TriangleKind::tip_cap: EXPECT_GT(glm::dot(n, c - glm::dvec3(0, 0, 2)), 0) << "triangle " << f; break;
        case TriangleKind::fusion: ADD_FAILURE() << "a fusion triangle without a fork"; break;
      }
    }
    // The volume of a polygon tube inscribed in the round cones (16 strands: loops of 5 to
    // 11 vertices) plus the tip's dome: somewhat less than the cones' 0.0367 m³.
    MeshCheckParams cp;
    cp.self_intersections = false;
    const double cones = std::numbers::pi * 0.4 / 3.0 *
                         [] {
                           double s = 0;
                           for (int i = 0; i < 5; ++i) {
                             const double r0 = 0.1 - 0.01 * i, r1 = r0 - 0.01;
                             s += r0 * r0 + r0 * r1 + r1 * r1;
                           }
                           return s;
                         }();
    const double volume = check_mesh(m, cp).signed_volume;
    EXPECT_GT(volume, 0.8 * cones);
    EXPECT_LT(volume, 1.0 * cones);
  }
}

TEST(BuildMesh, UvsInMetresKeepTexelDensityWhateverTheRadius) {
  // The straight branch tapers from 0.1 to 0.05 m. Once around, a strip triangle's UV area
  // over its area grows as 1 / r^2 up the branch; in metres it is 1 / uv_metres^2 everywhere.
  const test::UpToContours up = test::up_to_contours(test::straight_branch(6), 1);
  MeshParams metres, once;
  metres.uv_metres = 0.05;
  once.uv_metres = 0;
  for (const bool in_metres : {false, true}) {
    SCOPED_TRACE(in_metres ? "metres" : "once around");
    const MeshResult r = build_mesh(up.skeleton, up.contours, in_metres ? metres : once);
    const Mesh& m = r.mesh;
    ASSERT_EQ(m.corner_uvs.size(), m.triangle_count());
    double lo = 1e300, hi = 0;
    for (std::size_t f = 0; f < m.triangle_count(); ++f) {
      if (r.triangle_kind[f] != TriangleKind::strip) continue;
      const auto& t = m.triangles[f];
      const auto& uv = m.corner_uvs[f];
      const glm::vec2 a = uv[1] - uv[0], b = uv[2] - uv[0];
      const double uv_area = 0.5 * std::abs(double(a.x) * double(b.y) - double(a.y) * double(b.x));
      const double area = 0.5 * glm::length(m.face_normal(t));
      ASSERT_GT(area, 0);
      const double ratio = uv_area / area;
      lo = std::min(lo, ratio);
      hi = std::max(hi, ratio);
      // No triangle spans the seam the long way round: at most a third of a turn wide.
      const float du = std::max({uv[0].x, uv[1].x, uv[2].x}) - std::min({uv[0].x, uv[1].x, uv[2].x});
      EXPECT_LT(du, (in_metres ? 2 * std::numbers::pi * 0.1 / 0.05 : 1.0) / 3) << "triangle " << f;
    }
    if (in_metres) {
      EXPECT_GT(lo, 0.8 / (0.05 * 0.05));
      EXPECT_LT(hi, 1.25 / (0.05 * 0.05));
    } else {
      EXPECT_GT(hi / lo, 3.0);  // (0.1 / 0.05)^2 = 4, less the ends' averaging
    }
  }
}

TEST(BuildMesh, ForksGetPantsAndEveryTipADome) {
  struct Case {
    const char* name;
    RawSkeleton raw;
    std::size_t junctions, tips;
  };
  const Case cases[] = {{"y_fork", test::y_fork(35.0), 1, 2},
                        {"trifurcation", test::trifurcation(), 2, 3},
                        {"thick_child", test::thick_child(), 1, 2},
                        {"zero_length_edges", test::zero_length_edges(), 1, 2}};
  for (const Case& k : cases) {
    SCOPED_TRACE(k.name);
    const Built b = mesh_of(k.raw);
    expect_sound(b);
    expect_stitched_exactly(b);
    EXPECT_EQ(b.up.contours.junctions.size(), k.junctions);
    EXPECT_EQ(b.mesh.stats.tip_caps, k.tips);
    // Every triangle belongs to a branch of the skeleton (the id of its first node).
    const std::vector<std::uint32_t> branch = b.up.skeleton.branch_ids();
    for (const std::uint32_t id : b.mesh.mesh.triangle_branch) EXPECT_EQ(branch[id], id);
  }
}

TEST(BuildMesh, WhorlOfSixChildrenIsClosedGenusZero) {
  // Five forks a tiny step apart: stacked junctions, the hardest case for the pants.
  const Built b = mesh_of(test::six_children());
  expect_sound(b);
  EXPECT_EQ(b.mesh.stats.tip_caps, 6u);
  EXPECT_EQ(b.mesh.stats.junctions, 5u);
  // Each loop vertex is used; the caps add a ring and an apex per tip and the base's centre.
  std::size_t tip_vertices = 0;
  for (const Tube& t : b.up.contours.tubes) {
    if (t.end_junction == UINT32_MAX) tip_vertices += b.up.contours.loop_size(t.loops.back()) + 1;
  }
  EXPECT_LE(b.mesh.mesh.vertex_count(), b.up.contours.point.size() + tip_vertices + 1);
  EXPECT_GE(b.mesh.mesh.vertex_count(), b.up.contours.point.size() / 2);
}

TEST(BuildMesh, SameContoursSameMesh) {
  const Built a = mesh_of(test::y_fork(50.0));
  const MeshResult again = build_mesh(a.up.skeleton, a.up.contours);
  EXPECT_EQ(again.mesh.positions, a.mesh.mesh.positions);
  EXPECT_EQ(again.mesh.triangles, a.mesh.mesh.triangles);
}

}  // namespace
}  // namespace sm


namespace sm {
namespace {

TEST(BuildMesh, UvsFlowThroughForks) {
  // A Y fork meshed with the UVs in metres (the default): one seam per branch, so one seam edge
  // per strip (and per cap: two on a tip's dome, one on the base; one more where it crosses the
  // fusion askew), and at the junction at most three others (where the lateral's seam starts at its crotch, and the crotch triangles).
  // Around the fork the map stays close to square: the mismatch between the parent's last loop
  // and the children's first is spread up the children. (Before, each loop's u was its angle
  // around its own centre: junction anisotropy p95 17 and 67 at 35 and 60 degrees.)
  // Measured on the legacy rings (ring_edge 0). With the default rings at 60 degrees the
  // 8-strand loops keep 7 vertices and the crotch has two vertices where the seams meet, not
  // one: 5 other seams and a junction density p95 of 2.42 (legacy 3 and 1.74; anisotropy
  // 7.5 against 9.0), over 66 junction triangles.
  for (const bool legacy : {true, false}) {
  for (const double angle : {35.0, 60.0}) {
    SCOPED_TRACE(std::string(legacy ? "legacy rings, " : "default rings, ") + std::to_string(angle));
    ContourParams params;
    if (legacy) {
      params.ring_edge = 0;
      params.min_ring_vertices = 6;
    }
    const Built b = mesh_of(test::y_fork(angle), 1, params);
    expect_sound(b);
    const ContourSet& c = b.up.contours;
    std::size_t strips = 0, tips = 0;
    for (const Tube& t : c.tubes) {
      strips += t.loops.size() - 1 + (t.start_junction != UINT32_MAX ? 1 : 0);
      tips += t.end_junction == UINT32_MAX;
    }
    const UvQuality q = measure_uv_quality(b.mesh.mesh, &b.up.skeleton);
    EXPECT_LE(q.around_seams, strips + 2 * tips + 1 + c.junctions.size());  // (a seam may cross a fusion strip askew)
    EXPECT_LE(q.other_seams, legacy || angle < 45 ? 3u : 5u);
    EXPECT_GT(q.junction_triangles, 50u);
    EXPECT_LT(q.junction_anisotropy_p95, angle < 45 ? 5.0 : 12.0);
    EXPECT_LT(q.junction_density_p95, legacy || angle < 45 ? 2.0 : 2.5);
    EXPECT_LT(q.anisotropy_p95, 3.5);
    EXPECT_LE(q.flipped, 3u);
  }
  }
}

TEST(BuildMesh, UvsOfAStraightBranchAreSquareAndOfOneSize) {
  // Texels square and of one size along a tapering branch (0.1 to 0.05 m): u is the arc length
  // around each loop, v the distance along, both over uv_metres; one seam, one edge per strip.
  const Built b = mesh_of(test::straight_branch(6));
  const UvQuality q = measure_uv_quality(b.mesh.mesh, &b.up.skeleton);
  EXPECT_LT(q.anisotropy_p95, 1.15);
  EXPECT_LT(q.density_p95, 1.05);
  EXPECT_EQ(q.flipped, 0u);
  EXPECT_EQ(q.other_seams, 0u);
  // A seam edge per strip, two on the tip's dome (its ring, its pole) and one on the base.
  EXPECT_LE(q.around_seams, b.up.contours.loop_count() - 1 + 3);
  EXPECT_NEAR(q.density_median, 1.0 / MeshParams{}.uv_metres, 0.05 / MeshParams{}.uv_metres);
}

}  // namespace
}  // namespace sm
