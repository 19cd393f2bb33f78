#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <set>

#include <unistd.h>

#include "core/errors.h"
#include "core/file_io.h"
#include "core/progress.h"
#include "core/math.h"
#include "core/mesh.h"
#include "core/progress.h"
#include "core/report.h"
#include "core/rng.h"
#include "tests/mesh_fixtures.h"

namespace sm {
namespace {

TEST(Rng, SameSeedSameStream) {
  Rng a(42), b(42), c(43);
  bool differs = false;
  for (int i = 0; i < 100; ++i) {
    const auto x = a.next();
    EXPECT_EQ(x, b.next());
    differs |= x != c.next();
  }
  EXPECT_TRUE(differs);
}

TEST(Rng, UniformRangeAndMean) {
  Rng r(7);
  double sum = 0;
  for (int i = 0; i < 100000; ++i) {
    const double u = r.uniform();
    ASSERT_GE(u, 0.0);
    ASSERT_LT(u, 1.0);
    sum += u;
  }
  EXPECT_NEAR(sum / 100000, 0.5, 0.01);
  for (int i = 0; i < 1000; ++i) ASSERT_LT(r.below(7), 7u);
}

TEST(Rng, DerivedSeedsAreDistinct) {
  std::set<std::uint64_t> seen;
  for (std::uint64_t a = 0; a < 100; ++a)
    for (std::uint64_t b = 0; b < 10; ++b) seen.insert(derive_seed(1, a, b));
  EXPECT_EQ(seen.size(), 1000u);
  EXPECT_NE(derive_seed(1, 2), derive_seed(2, 1));
}

TEST(Warnings, CountsAndExamples) {
  Warnings w;
  for (int i = 0; i < 5; ++i) w.add("k", "a thing", "node " + std::to_string(i));
  w.add("j", "another");
  EXPECT_EQ(w.count("k"), 5u);
  EXPECT_EQ(w.total(), 6u);
  EXPECT_EQ(w.list()[0].examples.size(), 5u);  // all kept (up to max_kept_examples)
  EXPECT_NE(w.to_string().find("a thing (5x; e.g. node 0, node 1, node 2)"), std::string::npos);  // a few shown
}

TEST(OverallProgress, OnlyMovesForwardAcrossPhasesRetriesAndUnknownOnes) {
  OverallProgress p({{"a", 1}, {"b", 2}, {"c", 1}});
  EXPECT_DOUBLE_EQ(p.update("a", 0.5), 0.125);
  EXPECT_DOUBLE_EQ(p.update("b", 0.5), 0.5);
  EXPECT_DOUBLE_EQ(p.update("a", 1.0), 0.5);      // an earlier phase again (a retry): held
  EXPECT_DOUBLE_EQ(p.update("what", 0.9), 0.5);   // unknown: held
  EXPECT_DOUBLE_EQ(p.update("b", 0.25), 0.5);     // a phase restarting: held
  EXPECT_DOUBLE_EQ(p.update("c", 0.0), 0.75);
  EXPECT_DOUBLE_EQ(p.update("c", 2.0), 1.0);      // clamped
  EXPECT_DOUBLE_EQ(p.update("c", std::nan("")), 1.0);
  // The pipeline's table knows every phase the stages report, and the export.
  OverallProgress run = OverallProgress::pipeline();
  double last = 0;
  for (const char* phase : {"skeleton", "particles", "strands", "contours", "meshing", "fork retry", "outer surface", "repair", "export"}) {
    for (const double f : {0.0, 0.5, 1.0}) {
      const double now = run.update(phase, f);
      EXPECT_GE(now, last) << phase;
      last = now;
    }
    EXPECT_GT(last, 0.0) << phase;
  }
  EXPECT_DOUBLE_EQ(last, 1.0);
}

// snap_to_grid rounds without a library call; it must agree with std::nearbyint of the
// division bit for bit: ties to even, signed zeros, and values too large to have a fraction.
TEST(FloatGrid, SnapAgreesWithNearbyint) {
  auto reference = [](double x, double spacing) { return std::nearbyint(x / spacing) * spacing; };
  auto same_bits = [](double a, double b) { return std::signbit(a) == std::signbit(b) && (a == b); };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> xs = {0.0,    -0.0,       0.5,     -0.5, 1.5,          -1.5,
                            2.5,    -2.5,       0.3,     -0.3, 0x1p51 - 0.5, -(0x1p51 - 0.5),
                            0x1p51, 0x1p52 + 1, -0x1p60, 1e300};
  for (int k = 0; k < 20000; ++k) xs.push_back(unit(rng) * std::ldexp(1.0, k % 60 - 10));
  for (const double spacing : {1.0, 0x1p-20, float_grid(3.7), export_grid_spacing(120.0), 0x1p10}) {
    for (const double x0 : xs) {
      const double x = x0 * spacing;  // ties stay ties at every spacing (a power of two)
      const glm::dvec3 got = snap_to_grid(glm::dvec3(x, -x, 0.25 * x), spacing);
      EXPECT_TRUE(same_bits(got.x, reference(x, spacing))) << x << " at " << spacing;
      EXPECT_TRUE(same_bits(got.y, reference(-x, spacing))) << -x << " at " << spacing;
      EXPECT_TRUE(same_bits(got.z, reference(0.25 * x, spacing))) << 0.25 * x << " at " << spacing;
    }
  }
}

TEST(Frames, TransportKeepsOrthonormalAndMinimal) {
  Frame f;
  const dvec3 t = glm::normalize(dvec3(0.3, 0.1, 1));
  const Frame g = transport_frame(f, t);
  EXPECT_NEAR(glm::length(g.normal), 1, 1e-12);
  EXPECT_NEAR(glm::dot(g.normal, g.tangent), 0, 1e-12);
  EXPECT_NEAR(glm::dot(g.binormal, glm::cross(g.tangent, g.normal)), 1, 1e-12);
  // Transport back returns the original frame (no twist accumulates).
  const Frame h = transport_frame(g, f.tangent);
  EXPECT_NEAR(glm::length(h.normal - f.normal), 0, 1e-12);
  // Opposite tangent does not produce NaN.
  const Frame k = transport_frame(f, -f.tangent);
  EXPECT_TRUE(std::isfinite(k.normal.x));
  EXPECT_NEAR(glm::dot(k.normal, k.tangent), 0, 1e-12);
}

TEST(Normals, NoVertexNormalFacesAwayFromItsTriangles) {
  // Vertex 0 in three 90-degree corners facing +z and one 5-degree needle tilted 100 degrees
  // away from them: the angle-weighted sum is nearly +z and faces away from the needle; the
  // normal becomes the direction closest to all four (50 degrees from each).
  const double tilt = 100.0 * std::numbers::pi / 180.0, needle = 5.0 * std::numbers::pi / 180.0;
  const glm::dvec3 n4(std::sin(tilt), 0, std::cos(tilt)), t(-n4.z, 0, n4.x);
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {-1, 0, 0}, {0, -1, 0},
                 std::cos(needle) * glm::dvec3(0, 1, 0) + std::sin(needle) * t};
  m.triangles = {{0, 1, 2}, {0, 2, 3}, {0, 3, 4}, {0, 2, 5}};
  const std::vector<glm::dvec3> n = angle_weighted_normals(m);
  for (const auto& tri : m.triangles) {
    const glm::dvec3 fn = glm::normalize(m.face_normal(tri));
    for (const std::uint32_t v : tri) EXPECT_GT(glm::dot(n[v], fn), 0.6) << "vertex " << v;
  }
  EXPECT_NEAR(glm::dot(n[0], glm::dvec3(0, 0, 1)), std::cos(0.5 * tilt), 1e-12);
  EXPECT_NEAR(glm::dot(n[0], n4), std::cos(0.5 * tilt), 1e-12);
  // Where no triangle faces away, the normals are the angle-weighted sums as before (a box's
  // corner: equal thirds of the three faces).
  Mesh box;
  box.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  box.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}};
  EXPECT_NEAR(glm::dot(angle_weighted_normals(box)[0], glm::normalize(glm::dvec3(-1, -1, -1))), 1.0, 1e-12);
  // update_normals gives the same on the vertices it is asked for.
  Mesh u = m;
  u.normals.assign(u.positions.size(), glm::dvec3(0, 0, 1));
  const std::vector<std::uint32_t> all{0, 1, 2, 3, 4, 5};
  update_normals(u, all);
  EXPECT_EQ(u.normals, n);
}

// The largest angle (degrees) between a corner's normal and its triangle's, over all corners
// of triangles of non-zero area.
double worst_corner_angle(const Mesh& m, const std::vector<std::array<glm::vec3, 3>>& corner) {
  double worst = 0;
  for (std::size_t f = 0; f < m.triangles.size(); ++f) {
    const glm::dvec3 fn = m.face_normal(m.triangles[f]);
    if (!(glm::length(fn) > 0)) continue;
    for (const glm::vec3& n : corner[f]) {
      const double c = glm::dot(glm::dvec3(n), glm::normalize(fn));
      worst = std::max(worst, std::acos(std::clamp(c, -1.0, 1.0)) * 180.0 / std::numbers::pi);
    }
  }
  return worst;
}

TEST(SplitNormals, ASharpVSplitsIntoSmoothingGroupsWithNoneFacingAway) {
  // A 4-degree wedge: at the apex edge the two long sides meet at 176 degrees, and the vertex
  // normals there are about 88 degrees from both sides (a renderer shades them nearly black).
  const Mesh m = test::wedge(4.0);
  const std::vector<glm::dvec3> n = angle_weighted_normals(m);
  const glm::dvec3 right = glm::normalize(m.face_normal(m.triangles[4])),
                   left = glm::normalize(m.face_normal(m.triangles[6]));
  EXPECT_LT(glm::dot(n[2], right), std::cos(85.0 * std::numbers::pi / 180.0));
  const SplitNormals s = split_vertex_normals(m, vertex_corners(m), n, 91.0);
  ASSERT_EQ(s.corner_normals.size(), m.triangles.size());
  EXPECT_LE(worst_corner_angle(m, s.corner_normals), 80.0);
  // Every side is flat: at the apex vertices (2 and 5) its corners take its own normal.
  for (std::size_t f = 4; f < 8; ++f) {
    for (std::size_t k = 0; k < 3; ++k) {
      if (m.triangles[f][k] != 2 && m.triangles[f][k] != 5) continue;
      EXPECT_NEAR(glm::dot(glm::dvec3(s.corner_normals[f][k]), f < 6 ? right : left), 1.0, 1e-6) << f << " " << k;
    }
  }
  // Creases at 91 degrees: the apex edge (176) and the base's long edges (92). A base vertex
  // has one crease in its fan, which alone does not cut it, and its normal serves its three
  // faces (about 55 degrees from each): it keeps it. The apex vertices split in three groups
  // (an end, each side): 4 normals beyond one per vertex.
  EXPECT_EQ(s.split_vertices, 2u);
  EXPECT_EQ(s.extra_normals, 4u);
  const VertexCorners vc = vertex_corners(m);
  for (const std::uint32_t v : {0u, 1u, 3u, 4u}) {
    for (std::uint32_t i = vc.begin[v]; i < vc.begin[v + 1]; ++i) {
      const std::uint32_t c = vc.corner[i];
      EXPECT_NEAR(glm::length(glm::dvec3(s.corner_normals[c / 3][c % 3]) - n[v]), 0.0, 1e-7) << "vertex " << v;
    }
  }
  // At 45 degrees every edge of the wedge is a crease: three groups at every vertex.
  const SplitNormals hard = split_vertex_normals(m, vertex_corners(m), n, 45.0);
  EXPECT_EQ(hard.split_vertices, 6u);
  EXPECT_EQ(hard.extra_normals, 12u);
  EXPECT_NEAR(worst_corner_angle(m, hard.corner_normals), 0.0, 1e-3);
  // Without creases (crease angle 180) the apex still splits: no corner beyond 80 degrees.
  const SplitNormals g = split_vertex_normals(m, vertex_corners(m), n, 180.0);
  ASSERT_EQ(g.corner_normals.size(), m.triangles.size());
  EXPECT_LE(worst_corner_angle(m, g.corner_normals), 80.0);
  EXPECT_GE(g.split_vertices, 2u);
}

TEST(SplitNormals, AnyVertexNormalsComeOutServingEveryTriangle) {
  // Whatever the vertex normals given (here all pointing down, backward for half the
  // triangles), no corner ends more than max_angle from its triangle.
  for (const double max_angle : {80.0, 60.0}) {
    const Mesh m = test::wedge(20.0);
    const std::vector<glm::dvec3> down(m.positions.size(), glm::dvec3(0, 0, -1));
    const SplitNormals s = split_vertex_normals(m, vertex_corners(m), down, 180.0, max_angle);
    ASSERT_EQ(s.corner_normals.size(), m.triangles.size());
    EXPECT_LE(worst_corner_angle(m, s.corner_normals), max_angle + 1e-6);
  }
}

TEST(SplitNormals, SmoothFansKeepTheirVertexNormal) {
  // A cube's corners: three faces at 90 degrees, the normal 54.7 degrees from each; with a
  // crease angle above 90 no fan is split and the result is empty (one normal per vertex).
  const Mesh box = test::box();
  const std::vector<glm::dvec3> n = angle_weighted_normals(box);
  const SplitNormals s = split_vertex_normals(box, vertex_corners(box), n, 100.0);
  EXPECT_TRUE(s.corner_normals.empty());
  EXPECT_EQ(s.split_vertices, 0u);
  // At 45 degrees every edge is a crease: each corner takes its face's normal.
  const SplitNormals hard = split_vertex_normals(box, vertex_corners(box), n, 45.0);
  ASSERT_EQ(hard.corner_normals.size(), box.triangles.size());
  EXPECT_NEAR(worst_corner_angle(box, hard.corner_normals), 0.0, 1e-3);
  EXPECT_EQ(hard.extra_normals, 16u);  // 8 vertices, 3 normals each
  // Only the fans that need it split: a box and a sharp wedge in one mesh, at a crease angle
  // of 100 degrees, split only the wedge's apex vertices; every other vertex keeps its normal.
  const Mesh both = test::merged(box, test::translated(test::wedge(4.0), glm::dvec3(3, 0, 0)));
  const std::vector<glm::dvec3> bn = angle_weighted_normals(both);
  const SplitNormals some = split_vertex_normals(both, vertex_corners(both), bn, 100.0);
  ASSERT_EQ(some.corner_normals.size(), both.triangles.size());
  EXPECT_EQ(some.split_vertices, 2u);
  const VertexCorners vc = vertex_corners(both);
  for (std::uint32_t v = 0; v < both.positions.size(); ++v) {
    if (v == 8 + 2 || v == 8 + 5) continue;
    for (std::uint32_t i = vc.begin[v]; i < vc.begin[v + 1]; ++i) {
      const std::uint32_t c = vc.corner[i];
      EXPECT_NEAR(glm::length(glm::dvec3(some.corner_normals[c / 3][c % 3]) - bn[v]), 0.0, 1e-7) << "vertex " << v;
    }
  }
}

TEST(FileIo, AtomicWriteLeavesNoPartialFile) {
  const auto dir = std::filesystem::temp_directory_path() / ("sm_core_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const auto path = dir / "out.txt";
  write_file_atomically(path, "hello");
  EXPECT_EQ(read_file(path), "hello");
  EXPECT_THROW(write_file_atomically(path, [](std::ostream& out) {
                 out << "partial";
                 throw IoError("boom");
               }),
               IoError);
  EXPECT_EQ(read_file(path), "hello");  // untouched
  std::size_t files = 0;
  for ([[maybe_unused]] const auto& e : std::filesystem::directory_iterator(dir)) ++files;
  EXPECT_EQ(files, 1u);  // no temporary left behind
  EXPECT_THROW(write_file_atomically(dir / "missing" / "x.txt", "x"), IoError);
  EXPECT_THROW(read_file(dir / "nope.txt"), IoError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sm
