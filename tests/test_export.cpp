// Mesh export and import (meshio/export.h, meshio/mesh_io.h): seams, axes, precision,
// round trips, determinism, atomic writes, and readers that reject malformed files cleanly.

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/file_io.h"
#include "meshcheck/checks.h"
#include "meshcheck/quality.h"
#include "meshio/export.h"
#include "meshio/export_text.h"
#include "meshio/mesh_io.h"
#include "meshio/tree_attributes.h"
#include "tests/fixtures.h"
#include "tests/mesh_fixtures.h"

namespace sm {
namespace {

namespace fs = std::filesystem;
using glm::dvec3;

const std::vector<std::string> kExtensions = {"glb", "gltf", "obj", "ply"};

double max_position_error(const Mesh& a, const Mesh& b) {
  double e = 0;
  for (std::size_t i = 0; i < std::min(a.positions.size(), b.positions.size()); ++i) {
    e = std::max(e, glm::length(a.positions[i] - b.positions[i]));
  }
  return e;
}

// ---------------------------------------------------------------- splitting

TEST(ExportBuffers, WithoutSeamsKeepsTheWeldedVertices) {
  const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 16, 8, /*uvs=*/false);
  const ExportBuffers b = build_export_buffers(m, {.branch_ids = false, .optimize = false});
  ASSERT_EQ(b.positions.size(), m.positions.size());
  for (std::size_t i = 0; i < b.positions.size(); ++i) {
    EXPECT_EQ(b.source_vertex[i], i);
    EXPECT_EQ(b.positions[i], m.positions[i]);
  }
  EXPECT_EQ(b.indices.size(), 3 * m.triangles.size());
  EXPECT_TRUE(b.uvs.empty());
  EXPECT_EQ(b.normals.size(), b.positions.size());
}

TEST(ExportBuffers, SplitsOnlyWhereUvsDiffer) {
  const int n = 16, rings = 8;
  const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, n, rings, /*uvs=*/true);
  const ExportBuffers b = build_export_buffers(m, {.branch_ids = false, .optimize = false});
  // Welded: (rings+1)·n + 2. The u = 0/1 seam adds one copy per row, each cap adds a copy of
  // its n rim vertices (planar cap UVs); the cap centres do not split.
  const std::size_t welded = (rings + 1) * n + 2;
  EXPECT_EQ(m.positions.size(), welded);
  EXPECT_EQ(b.positions.size(), welded + (rings + 1) + 2 * n);
  // Every corner's UV survives, and copies of one vertex share its position.
  for (std::size_t c = 0; c < b.indices.size(); ++c) {
    EXPECT_EQ(b.uvs[b.indices[c]], m.corner_uvs[c / 3][c % 3]);
    EXPECT_EQ(b.positions[b.indices[c]], m.positions[m.triangles[c / 3][c % 3]]);
  }
}

TEST(ExportBuffers, SplitsAtBranchBoundariesOnlyWhenWritingBranchIds) {
  const int n = 16, rings = 8;
  const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, n, rings, /*uvs=*/false, /*upper_branch=*/7);
  EXPECT_EQ(build_export_buffers(m, {.branch_ids = false}).positions.size(), m.positions.size());
  const ExportBuffers b = build_export_buffers(m, {.branch_ids = true});
  EXPECT_EQ(b.positions.size(), m.positions.size() + n);  // the ring between the two branches
  std::size_t sevens = 0;
  for (const auto id : b.branch) sevens += id == 7;
  EXPECT_GT(sevens, 0u);
}

TEST(ExportBuffers, OptimizeKeepsTheMesh) {
  const Mesh m = test::capped_tube();
  const ExportBuffers plain = build_export_buffers(m, {.optimize = false});
  const ExportBuffers opt = build_export_buffers(m, {.optimize = true});
  ASSERT_EQ(plain.positions.size(), opt.positions.size());
  ASSERT_EQ(plain.indices.size(), opt.indices.size());
  // Same set of triangles (as position/uv triples, rotated to a canonical start).
  auto triangles = [](const ExportBuffers& b) {
    std::vector<std::array<double, 15>> out;
    for (std::size_t i = 0; i < b.indices.size(); i += 3) {
      std::array<std::array<double, 5>, 3> c{};
      for (std::size_t k = 0; k < 3; ++k) {
        const auto v = b.indices[i + k];
        c[k] = {b.positions[v].x, b.positions[v].y, b.positions[v].z, b.uvs[v].x, b.uvs[v].y};
      }
      const auto first = std::min_element(c.begin(), c.end()) - c.begin();
      std::rotate(c.begin(), c.begin() + first, c.end());
      std::array<double, 15> flat{};
      for (std::size_t k = 0; k < 3; ++k) std::copy(c[k].begin(), c[k].end(), flat.begin() + 5 * k);
      out.push_back(flat);
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  EXPECT_EQ(triangles(plain), triangles(opt));
  EXPECT_NE(plain.indices, opt.indices);
}

TEST(ExportBuffers, RejectsInvalidMeshes) {
  Mesh m = test::box();
  m.triangles.push_back({0, 1, 42});
  EXPECT_THROW(build_export_buffers(m), InvalidInputError);
  Mesh n = test::box();
  n.normals.resize(3);
  EXPECT_THROW(build_export_buffers(n), InvalidInputError);
}

// ---------------------------------------------------------------- round trips

TEST(Export, RoundTripEveryFormat) {
  const fs::path dir = test::temp_dir("export_roundtrip");
  const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 16, 8, true, 7);
  const MeshCheckReport before = check_mesh(m);
  ASSERT_TRUE(before.ok()) << to_text(before);
  for (const auto& ext : kExtensions) {
    SCOPED_TRACE(ext);
    const fs::path path = dir / ("tube." + ext);
    write_mesh(m, path, {.optimize = false});
    const Mesh back = read_mesh(path);
    // Welded again: same vertices in the same order, same triangles.
    ASSERT_EQ(back.positions.size(), m.positions.size());
    ASSERT_EQ(back.triangles.size(), m.triangles.size());
    EXPECT_EQ(back.triangles, m.triangles);
    EXPECT_LT(max_position_error(back, m), ext == "ply" ? 0.0 + 1e-15 : 1e-6);
    ASSERT_EQ(back.corner_uvs.size(), m.corner_uvs.size());
    EXPECT_EQ(back.corner_uvs, m.corner_uvs);
    ASSERT_EQ(back.normals.size(), m.positions.size());
    const auto expected_normals = angle_weighted_normals(m);
    for (std::size_t i = 0; i < back.normals.size(); ++i)
      EXPECT_NEAR(glm::length(back.normals[i] - expected_normals[i]), 0, 1e-6);
    if (ext == "glb" || ext == "gltf") {
      EXPECT_EQ(back.triangle_branch, m.triangle_branch);
    } else {
      EXPECT_TRUE(back.triangle_branch.empty());
    }
    const MeshCheckReport after = check_mesh(back);
    EXPECT_TRUE(after.ok()) << to_text(after);
    EXPECT_EQ(after.edges, before.edges);
    EXPECT_EQ(after.euler_characteristic, before.euler_characteristic);
  }
}

TEST(Export, SmoothingGroupsSplitVerticesAndReadBackWelded) {
  // A sharp wedge with smoothing groups next to a smooth torus: the writers add a vertex per
  // extra group at the wedge and none at the torus; every reader welds the file back to the
  // same closed mesh and keeps the corner normals, so that the check measures them.
  const Mesh wedge = test::wedge(4.0), torus = test::torus();
  Mesh m = test::merged(torus, test::translated(wedge, {3, 0, 0}));
  m.normals = angle_weighted_normals(m);
  // (A crease angle of 45 degrees: every edge of the wedge, none of the torus, 30 at most.)
  const SplitNormals split = split_vertex_normals(m, vertex_corners(m), m.normals, 45.0);
  m.corner_normals = split.corner_normals;
  ASSERT_EQ(m.corner_normals.size(), m.triangles.size());
  EXPECT_EQ(split.split_vertices, 6u);  // the wedge's, in three groups each
  EXPECT_EQ(split.extra_normals, 12u);

  // A smooth surface alone gets no corner normals: its vertices are written once.
  Mesh smooth = torus;
  smooth.normals = angle_weighted_normals(smooth);
  EXPECT_TRUE(split_vertex_normals(smooth, vertex_corners(smooth), smooth.normals, 90.0).corner_normals.empty());
  EXPECT_EQ(build_export_buffers(smooth, {.optimize = false}).positions.size(), smooth.positions.size());

  const ExportBuffers b = build_export_buffers(m, {.optimize = false});
  EXPECT_EQ(b.positions.size(), m.positions.size() + split.extra_normals);
  const MeshCheckReport before = check_mesh(m);  // (two components: not ok() as a tree)
  ASSERT_TRUE(before.closed && before.oriented && before.vertex_manifold) << to_text(before);
  ASSERT_EQ(before.genus, 1);
  const fs::path dir = test::temp_dir("export_split_normals");
  for (const auto& ext : kExtensions) {
    SCOPED_TRACE(ext);
    const fs::path path = dir / ("m." + ext);
    write_mesh(m, path);
    const Mesh back = read_mesh(path);
    EXPECT_EQ(back.positions.size(), m.positions.size());
    EXPECT_EQ(back.triangles.size(), m.triangles.size());
    ASSERT_EQ(back.corner_normals.size(), back.triangles.size());
    const MeshCheckReport after = check_mesh(back);
    EXPECT_TRUE(after.closed && after.oriented && after.vertex_manifold) << to_text(after);
    EXPECT_EQ(after.edges, before.edges);
    EXPECT_EQ(after.euler_characteristic, before.euler_characteristic);
    EXPECT_EQ(after.components, before.components);
    EXPECT_EQ(after.genus, before.genus);
    EXPECT_EQ(after.self_intersecting_pairs, 0u);
    const TriangleQuality q = measure_quality(back);
    EXPECT_TRUE(q.normals_per_corner);
    EXPECT_EQ(q.backward_normals, 0u);
    // Without split normals in the mesh the same file has one normal per vertex.
    Mesh plain = m;
    plain.corner_normals.clear();
    write_mesh(plain, path);
    EXPECT_TRUE(read_mesh(path).corner_normals.empty());
  }
}

TEST(Export, OptimizedRoundTripKeepsTopology) {
  const fs::path dir = test::temp_dir("export_roundtrip_opt");
  const Mesh m = test::icosphere(3);
  for (const auto& ext : kExtensions) {
    SCOPED_TRACE(ext);
    write_mesh(m, dir / ("s." + ext));
    const Mesh back = read_mesh(dir / ("s." + ext));
    EXPECT_EQ(back.positions.size(), m.positions.size());
    EXPECT_EQ(back.triangles.size(), m.triangles.size());
    const MeshCheckReport r = check_mesh(back);
    EXPECT_TRUE(r.ok()) << to_text(r);
    EXPECT_NEAR(r.signed_volume, check_mesh(m).signed_volume, 1e-5);
  }
}

TEST(Export, SameMeshSameBytes) {
  const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 16, 8, true, 3);
  for (const MeshFormat f : {MeshFormat::glb, MeshFormat::gltf, MeshFormat::obj, MeshFormat::ply}) {
    EXPECT_EQ(encode_mesh(m, f), encode_mesh(m, f));
  }
}

// The buffer of a .glb (its BIN chunk, padding dropped) and of a .gltf (its base64 data URI,
// decoded); both are written chunk by chunk, the latter encoded as it goes.
std::string glb_buffer(const std::string& glb) {
  std::uint32_t json_length = 0, bin_length = 0;
  std::memcpy(&json_length, glb.data() + 12, 4);
  std::memcpy(&bin_length, glb.data() + 20 + json_length, 4);
  const auto json = nlohmann::json::parse(glb.substr(20, json_length));
  return glb.substr(28 + json_length, json["buffers"][0]["byteLength"].get<std::size_t>());
}
std::string gltf_buffer(const std::string& gltf) {
  const auto json = nlohmann::json::parse(gltf);
  const std::string uri = json["buffers"][0]["uri"].get<std::string>();
  const std::string prefix = "data:application/octet-stream;base64,";
  EXPECT_EQ(uri.rfind(prefix, 0), 0u);
  const std::string alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::uint32_t bits = 0;
  int have = 0;
  for (const char c : uri.substr(prefix.size())) {
    if (c == '=') break;
    const std::size_t v = alphabet.find(c);
    EXPECT_NE(v, std::string::npos);
    bits = (bits << 6) | std::uint32_t(v);
    if ((have += 6) >= 8) out.push_back(static_cast<char>((bits >> (have -= 8)) & 0xFF));
  }
  EXPECT_EQ((uri.size() - prefix.size()) % 4, 0u);
  EXPECT_EQ(out.size(), json["buffers"][0]["byteLength"].get<std::size_t>());
  return out;
}

TEST(Export, GltfAndGlbCarryTheSameBuffer) {
  // Tubes of 5 to 8 sides and 1 to 3 rings, without UVs (with them every attribute is a
  // multiple of 3 bytes per vertex): buffers of each length modulo 3 (the base64 encoder's
  // partial last group).
  std::set<std::size_t> remainders;
  for (int k = 0; k < 12; ++k) {
    const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 5 + k % 4, 1 + k / 4, false, 2);
    const std::string bin = glb_buffer(encode_mesh(m, MeshFormat::glb));
    EXPECT_EQ(gltf_buffer(encode_mesh(m, MeshFormat::gltf)), bin);
    remainders.insert(bin.size() % 3);
  }
  EXPECT_EQ(remainders.size(), 3u);
}

TEST(Export, GltfIsYUpAndKeepsTheOrientation) {
  // z-up input: the exported glTF, read without conversion, is (x, z, -y).
  const Mesh m = test::translated(test::capped_tube({0, 0, 0}, {0.3, 0.2, 1}, 0.1), {1, 2, 3});
  const std::string bytes = encode_mesh(m, MeshFormat::glb, {.up_axis = UpAxis::z, .optimize = false});
  const Mesh raw = parse_mesh(bytes, MeshFormat::glb, "t.glb", {.up_axis = UpAxis::y});
  ASSERT_EQ(raw.positions.size(), m.positions.size());
  for (std::size_t i = 0; i < m.positions.size(); ++i) {
    const dvec3 p = m.positions[i];
    EXPECT_LT(glm::length(raw.positions[i] - dvec3(p.x, p.z, -p.y)), 1e-6);
  }
  EXPECT_GT(check_mesh(raw).signed_volume, 0);  // a rotation: still outward
  // Read back as z-up: the original coordinates.
  EXPECT_LT(max_position_error(parse_mesh(bytes, MeshFormat::glb, "t.glb", {.up_axis = UpAxis::z}), m), 1e-6);
  // y-up input is written unchanged.
  const std::string ybytes = encode_mesh(m, MeshFormat::glb, {.up_axis = UpAxis::y, .optimize = false});
  EXPECT_LT(max_position_error(parse_mesh(ybytes, MeshFormat::glb, "t.glb", {.up_axis = UpAxis::y}), m), 1e-6);
  // OBJ and PLY come back in the input's axes whatever they were written with.
  const Mesh obj =
      parse_mesh(encode_mesh(m, MeshFormat::obj, {.up_axis = UpAxis::z, .optimize = false}), MeshFormat::obj, "t.obj");
  EXPECT_LT(max_position_error(obj, m), 1e-6);
}

// ---------------------------------------------------------------- placement

// A trunk from its base at `root` 1 m up the z axis (and a little sideways), z-up.
Mesh trunk_at(const dvec3& root) { return test::translated(test::capped_tube({0, 0, 0}, {0.3, 0.2, 1}, 0.1), root); }

Mesh file_coords(const std::string& bytes, MeshFormat f) {
  return parse_mesh(bytes, f, "t", {.file_coordinates = true});
}

TEST(Placement, RootLandsAtTheOriginAndUpIsUpInEveryFormat) {
  const dvec3 root(1, 2, 3);
  const Mesh m = trunk_at(root);
  // The tube's bottom cap centre is vertex #V - 2, at the root; its top cap centre, 1 m up.
  const dvec3 top = m.positions[m.positions.size() - 1] - root;
  for (const MeshFormat f : {MeshFormat::glb, MeshFormat::gltf, MeshFormat::obj, MeshFormat::ply}) {
    SCOPED_TRACE(int(f));
    const std::string bytes = encode_mesh(m, f, {.root = root, .optimize = false});
    const Mesh raw = file_coords(bytes, f);
    ASSERT_EQ(raw.positions.size(), m.positions.size());
    const dvec3 base = raw.positions[m.positions.size() - 2], tip = raw.positions[m.positions.size() - 1];
    if (f == MeshFormat::ply) {  // PLY: as given, z-up and absolute
      EXPECT_LT(glm::length(base - root), 1e-12);
      EXPECT_LT(glm::length(tip - base - top), 1e-12);
    } else {  // glTF and OBJ: y-up, the root at the origin
      EXPECT_LT(glm::length(base), 1e-12);
      EXPECT_LT(glm::length(tip - dvec3(top.x, top.z, -top.y)), 1e-6);
      EXPECT_NEAR(tip.y, 1.0, 1e-6);  // up is +y
    }
    // Read back normally: the original coordinates, and still outward.
    const Mesh back = parse_mesh(bytes, f, "t");
    EXPECT_LT(max_position_error(back, m), 1e-6);
    EXPECT_GT(check_mesh(back).signed_volume, 0);
  }
  // glTF keeps the root in the node's translation (y-up): the tree stays where it was.
  const nlohmann::json gltf = nlohmann::json::parse(encode_mesh(m, MeshFormat::gltf, {.root = root}));
  EXPECT_EQ(gltf["nodes"][0]["translation"], nlohmann::json::array({1.0, 3.0, -2.0}));
  EXPECT_EQ(gltf["asset"]["extras"]["strandmesh"]["up_axis"], "y");
}

TEST(Placement, UpAxisPivotAndScaleOptions) {
  const dvec3 root(1, 2, 3);
  const Mesh m = trunk_at(root);
  const std::size_t base = m.positions.size() - 2, tip = m.positions.size() - 1;
  // z-up OBJ, root pivot: the input's axes, shifted.
  Mesh raw = file_coords(encode_mesh(m, MeshFormat::obj, {.file_up_axis = UpAxis::z, .root = root, .optimize = false}),
                         MeshFormat::obj);
  EXPECT_LT(glm::length(raw.positions[tip] - (m.positions[tip] - root)), 1e-6);
  // y-up PLY with the bounding-box centre as pivot: centred, up is +y.
  raw = file_coords(encode_mesh(m, MeshFormat::ply, {.file_up_axis = UpAxis::y, .pivot = Pivot::center, .optimize = false}),
                    MeshFormat::ply);
  dvec3 lo(1e9), hi(-1e9);
  for (const dvec3& p : raw.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
  EXPECT_LT(glm::length(lo + hi), 1e-3);  // snapped to the export grid
  EXPECT_GT(raw.positions[tip].y, raw.positions[base].y + 0.9);
  // Centimetres: 100 times the coordinates, read back in metres.
  for (const MeshFormat f : {MeshFormat::glb, MeshFormat::obj, MeshFormat::ply}) {
    const std::string bytes = encode_mesh(m, f, {.root = root, .scale = 100, .optimize = false});
    raw = file_coords(bytes, f);
    const dvec3 d = raw.positions[tip] - raw.positions[base];
    EXPECT_NEAR(glm::length(d), 100 * glm::length(m.positions[tip] - m.positions[base]), 1e-3);
    EXPECT_LT(max_position_error(parse_mesh(bytes, f, "t"), m), 1e-6);
  }
  // Without a root, the pivot is the bottom centre of the bounds.
  raw = file_coords(encode_mesh(m, MeshFormat::obj, {.optimize = false}), MeshFormat::obj);
  lo = dvec3(1e9);
  for (const dvec3& p : raw.positions) lo = glm::min(lo, p);
  EXPECT_NEAR(lo.y, 0.0, 1e-6);  // the pivot is on the export grid
  EXPECT_THROW(encode_mesh(m, MeshFormat::obj, {.scale = 0}), InvalidInputError);
}

TEST(Placement, AttributeNames) {
  // (The config's `export` section: test_pipeline.cpp, ExportSectionFromTheTable.)
  ExportParams p;
  EXPECT_THROW(set_attributes("normal,brnch_id", p), InvalidInputError);
  set_attributes("all", p);
  EXPECT_EQ(attribute_list(p), "normal,uv,branch_id,level,root_distance,pivot,direction,phase,thickness,color,uv1,tangent");
  set_attributes("normal,wind", p);
  EXPECT_EQ(attribute_list(p), "normal,level,root_distance,pivot,direction,phase,thickness");
  EXPECT_EQ(parse_scale("cm"), 100.0);
  EXPECT_EQ(parse_pivot("centre"), Pivot::center);
  EXPECT_THROW(parse_up_axis("x"), InvalidInputError);
}

// ---------------------------------------------------------------- compression

// The accessor component type of the primitive's indices in a .gltf text file.
int index_component_type(const std::string& gltf) {
  const nlohmann::json j = nlohmann::json::parse(gltf);
  return j["accessors"][j["meshes"][0]["primitives"][0]["indices"].get<int>()]["componentType"].get<int>();
}

TEST(Compression, EveryVariantReadsBackWithItsTopology) {
  const Mesh m = test::translated(test::capped_tube({0, 0, 0}, {0.3, 0.2, 2}, 0.1, 24, 12, true, 5), {10, 20, 30});
  const std::size_t plain = encode_mesh(m, MeshFormat::glb).size();
  for (const bool quantize : {false, true}) {
    for (const Compression c : {Compression::none, Compression::meshopt}) {
      for (const MeshFormat f : {MeshFormat::glb, MeshFormat::gltf}) {
        SCOPED_TRACE(std::to_string(quantize) + " " + std::to_string(int(c)) + " " + std::to_string(int(f)));
        const ExportParams p{.compress = c, .quantize = quantize};
        const std::string bytes = encode_mesh(m, f, p);
        EXPECT_EQ(bytes, encode_mesh(m, f, p));  // deterministic
        const Mesh back = parse_mesh(bytes, f, "t");
        ASSERT_EQ(back.triangles.size(), m.triangles.size());
        ASSERT_EQ(back.positions.size(), m.positions.size());  // nothing welded together
        const MeshCheckReport r = check_mesh(back);
        EXPECT_TRUE(r.ok()) << to_text(r);
        // Every position within half a quantization step (2 m tall: 16 bits give 31 µm).
        double worst = 0;
        for (const dvec3& q : back.positions) {
          double best = 1e300;
          for (const dvec3& x : m.positions) best = std::min(best, glm::length(q - x));
          worst = std::max(worst, best);
        }
        EXPECT_LT(worst, quantize ? 3e-5 : 1e-5);
        ASSERT_EQ(back.triangle_branch.size(), m.triangles.size());
        if (c == Compression::meshopt && f == MeshFormat::glb) {
          EXPECT_LT(bytes.size(), quantize ? plain / 2 : plain);
        }
      }
    }
  }
  // 16-bit indices while the vertices fit, 32-bit beyond.
  EXPECT_EQ(index_component_type(encode_mesh(m, MeshFormat::gltf)), 5123);  // UNSIGNED_SHORT
  const Mesh big = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 400, 200);
  ASSERT_GT(big.positions.size(), 65536u);
  EXPECT_EQ(index_component_type(encode_mesh(big, MeshFormat::gltf, {.uvs = false})), 5125);  // UNSIGNED_INT
  EXPECT_TRUE(check_mesh(parse_mesh(encode_mesh(big, MeshFormat::glb, {.compress = Compression::meshopt}), MeshFormat::glb, "b")).ok());
}

TEST(Lods, LevelsInOneGltfFileWithMsftLod) {
  // Three levels of one tube at a georeferenced place, finest first.
  const dvec3 at{500000, 5200000, 300};
  const std::vector<Mesh> meshes{test::translated(test::capped_tube({0, 0, 0}, {0, 0, 2}, 0.1, 24, 12), at),
                                 test::translated(test::capped_tube({0, 0, 0}, {0, 0, 2}, 0.1, 12, 6), at),
                                 test::translated(test::capped_tube({0, 0, 0}, {0, 0, 2}, 0.1, 6, 2), at)};
  std::vector<ExportLevel> levels;
  for (const Mesh& m : meshes) levels.push_back({&m, nullptr});
  for (const bool quantize : {false, true}) {
    for (const Compression c : {Compression::none, Compression::meshopt}) {
      SCOPED_TRACE(std::to_string(quantize) + " " + std::to_string(int(c)));
      const ExportParams p{.root = at, .compress = c, .quantize = quantize};
      const std::string text = encode_mesh_levels(levels, MeshFormat::gltf, p);
      EXPECT_EQ(text, encode_mesh_levels(levels, MeshFormat::gltf, p));  // deterministic
      const nlohmann::json j = nlohmann::json::parse(text);
      // Level 0's node is the scene; MSFT_lod on it names the others, which are outside the scene.
      ASSERT_EQ(j["scenes"][0]["nodes"], nlohmann::json::array({0}));
      const nlohmann::json& top = j["nodes"][0];
      EXPECT_EQ(top["name"], "tree");
      const std::vector<int> ids = top["extensions"]["MSFT_lod"]["ids"];
      EXPECT_EQ(ids, quantize ? std::vector<int>({2, 4}) : std::vector<int>({1, 2}));
      EXPECT_EQ(j["nodes"][ids[0]]["name"], "tree_lod1");
      EXPECT_EQ(j["nodes"][ids[1]]["name"], "tree_lod2");
      EXPECT_EQ(j["meshes"].size(), 3u);
      // Screen coverage per level, decreasing, the last level never culled.
      const std::vector<double> cover = top["extras"]["MSFT_screencoverage"];
      ASSERT_EQ(cover.size(), 3u);
      EXPECT_GT(cover[0], cover[1]);
      EXPECT_GT(cover[1], cover[2]);
      EXPECT_EQ(cover[2], 0.0);
      EXPECT_NEAR(cover[0], 0.5 * double(meshes[1].triangle_count()) / double(meshes[0].triangle_count()), 1e-12);
      // Used, not required: a client without it shows level 0.
      const auto used = j["extensionsUsed"].get<std::vector<std::string>>();
      EXPECT_NE(std::find(used.begin(), used.end(), "MSFT_lod"), used.end());
      if (j.contains("extensionsRequired")) {
        const auto required = j["extensionsRequired"].get<std::vector<std::string>>();
        EXPECT_EQ(std::find(required.begin(), required.end(), "MSFT_lod"), required.end());
      }
      // Every level reads back with its own triangles, in place (the same pivot).
      for (std::size_t k = 0; k < meshes.size(); ++k) {
        for (const MeshFormat f : {MeshFormat::gltf, MeshFormat::glb}) {
          const std::string bytes = f == MeshFormat::gltf ? text : encode_mesh_levels(levels, f, p);
          const Mesh back = parse_mesh(bytes, f, "t", {.lod = static_cast<std::uint32_t>(k)});
          EXPECT_EQ(back.triangle_count(), meshes[k].triangle_count());
          EXPECT_TRUE(check_mesh(back).ok()) << to_text(check_mesh(back));
          double worst = 0;  // every vertex read back lies on one of the level's own
          for (const dvec3& q : back.positions) {
            double best = 1e300;
            for (const dvec3& x : meshes[k].positions) best = std::min(best, glm::length(q - x));
            worst = std::max(worst, best);
          }
          EXPECT_LT(worst, quantize ? 3e-5 : 1e-5);
        }
      }
      EXPECT_THROW((void)parse_mesh(text, MeshFormat::gltf, "t", {.lod = 3}), InvalidInputError);
    }
  }
  // One level is the plain file; without MSFT_lod a level > 0 is an error; OBJ and PLY hold one level.
  EXPECT_EQ(encode_mesh_levels({levels.data(), 1}, MeshFormat::glb), encode_mesh(meshes[0], MeshFormat::glb));
  EXPECT_THROW((void)parse_mesh(encode_mesh(meshes[0], MeshFormat::glb), MeshFormat::glb, "t", {.lod = 1}), InvalidInputError);
  EXPECT_THROW((void)encode_mesh_levels(levels, MeshFormat::obj), InvalidInputError);
  EXPECT_THROW((void)parse_mesh(encode_mesh(meshes[0], MeshFormat::ply), MeshFormat::ply, "t", {.lod = 1}), InvalidInputError);
}

TEST(Compression, MalformedMeshoptDataIsAnErrorNotACrash) {
  const Mesh m = test::capped_tube();
  std::string bytes = encode_mesh(m, MeshFormat::glb, {.compress = Compression::meshopt});
  // Flip bytes of the BIN chunk (after the JSON): every result is a mesh or an InvalidInputError.
  std::uint32_t json = 0;
  std::memcpy(&json, bytes.data() + 12, 4);
  for (std::size_t at = 20 + json + 8; at < bytes.size(); at += 7) {
    std::string bad = bytes;
    bad[at] = static_cast<char>(bad[at] ^ 0x5A);
    try {
      (void)parse_mesh(bad, MeshFormat::glb, "bad.glb");
    } catch (const InvalidInputError&) {
    }
  }
  std::string cut = bytes.substr(0, bytes.size() - 16);
  EXPECT_THROW((void)parse_mesh(cut, MeshFormat::glb, "cut.glb"), InvalidInputError);
}

// ---------------------------------------------------------------- tree attributes

// Root (0,0,0) r 0.2 -> node 1 (0,0,1) r 0.1 -> node 2 (0,0,2) r 0.05 (main), and a lateral
// node 3 at (1,0,1) r 0.05 from node 1.
Skeleton small_fork() {
  Skeleton s;
  const NodeId root = s.add_node(NodeId(), {0, 0, 0}, 0.2);
  const NodeId n1 = s.add_node(root, {0, 0, 1}, 0.1);
  s.add_node(n1, {0, 0, 2}, 0.05);
  s.add_node(n1, {1, 0, 1}, 0.05);
  return s;
}

TEST(TreeAttributes, ValuesOnASmallFork) {
  const Skeleton s = small_fork();
  Mesh m;  // one vertex per place of interest (no triangles are needed)
  m.positions = {{0.2, 0, 0.5}, {0, 0.05, 1.5}, {0.5, 0.05, 1.0}, {0.1, 0, -0.1}};
  m.vertex_node = {NodeId(1u), NodeId(2u), NodeId(3u), NodeId(0u)};
  const TreeAttributes a = compute_tree_attributes(m, s);
  // Distance along the tree and the radius there, interpolated along the nearest edge.
  EXPECT_FLOAT_EQ(a.root_distance[0], 0.5f);
  EXPECT_FLOAT_EQ(a.thickness[0], 0.15f);
  EXPECT_FLOAT_EQ(a.root_distance[1], 1.5f);
  EXPECT_FLOAT_EQ(a.thickness[1], 0.075f);
  EXPECT_FLOAT_EQ(a.root_distance[2], 1.5f);  // 1 m up the trunk, then 0.5 m out along the lateral
  EXPECT_FLOAT_EQ(a.thickness[2], 0.075f);
  EXPECT_FLOAT_EQ(a.root_distance[3], 0.0f);  // below the root: clamped to it
  EXPECT_FLOAT_EQ(a.max_root_distance, 1.5f);
  // Branches: the trunk (id 0: nodes 0, 1, 2) and the lateral (id 3).
  EXPECT_EQ(a.vertex_branch, (std::vector<std::uint32_t>{0, 0, 3, 0}));
  EXPECT_EQ(a.level[0], 0u);
  EXPECT_EQ(a.level[3], 1u);
  EXPECT_EQ(a.max_level, 1u);
  EXPECT_EQ(a.pivot[3], dvec3(0, 0, 1));  // where it leaves the trunk
  EXPECT_EQ(a.direction[3], dvec3(1, 0, 0));
  EXPECT_EQ(a.pivot[0], dvec3(0, 0, 0));
  EXPECT_EQ(a.direction[0], dvec3(0, 0, 1));
  EXPECT_GE(a.phase[3], 0.0f);
  EXPECT_LT(a.phase[3], 1.0f);
  EXPECT_NE(a.phase[0], a.phase[3]);
  EXPECT_EQ(compute_tree_attributes(m, s).phase, a.phase);  // deterministic
  m.vertex_node.clear();
  EXPECT_THROW(compute_tree_attributes(m, s), InvalidInputError);
}

// The float values of attribute `name` of a .glb's first primitive (plain float accessors).
std::vector<float> glb_floats(const std::string& glb, const std::string& name) {
  std::uint32_t json_length = 0;
  std::memcpy(&json_length, glb.data() + 12, 4);
  const auto json = nlohmann::json::parse(glb.substr(20, json_length));
  const std::string bin = glb_buffer(glb);
  const auto& acc = json["accessors"][json["meshes"][0]["primitives"][0]["attributes"][name].get<int>()];
  const auto& view = json["bufferViews"][acc["bufferView"].get<int>()];
  const std::size_t n = acc["count"].get<std::size_t>() * (acc["type"] == "SCALAR" ? 1 : acc["type"] == "VEC2" ? 2 : acc["type"] == "VEC3" ? 3 : 4);
  std::vector<float> out(n);
  std::memcpy(out.data(), bin.data() + view.value("byteOffset", std::size_t{0}), n * sizeof(float));
  return out;
}

TEST(TreeAttributes, ExportedPerVertexInTheFileFrame) {
  // A tube along the trunk's first edge, every vertex made by node 1.
  const Skeleton s = small_fork();
  Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 12, 6, true);
  m.vertex_node.assign(m.positions.size(), NodeId(1u));
  m.triangle_branch.assign(m.triangles.size(), 0u);
  ExportParams p{.root = dvec3(0), .optimize = false, .skeleton = &s};
  set_attributes("all", p);
  const std::string glb = encode_mesh(m, MeshFormat::glb, p);
  const std::vector<float> pos = glb_floats(glb, "POSITION"), dist = glb_floats(glb, "_ROOT_DISTANCE"),
                           thick = glb_floats(glb, "_THICKNESS"), tangent = glb_floats(glb, "TANGENT"),
                           normal = glb_floats(glb, "NORMAL"), pivot = glb_floats(glb, "_BRANCH_PIVOT");
  ASSERT_EQ(dist.size() * 3, pos.size());
  for (std::size_t i = 0; i < dist.size(); ++i) {
    const float up = pos[3 * i + 1];  // y-up file: below node 1 the height is the root distance
    if (up < 0.99f) {  // (at node 1's height the lateral edge may be nearer)
      EXPECT_NEAR(dist[i], std::max(up, 0.0f), 1e-6);
      EXPECT_NEAR(thick[i], 0.2f - 0.1f * std::max(up, 0.0f), 1e-6);
    }
    EXPECT_EQ(pivot[3 * i + 1], 0.0f);  // the trunk's pivot: the root, at the file's origin
    // Tangents: unit, across the normal, w = +-1.
    const glm::vec3 t(tangent[4 * i], tangent[4 * i + 1], tangent[4 * i + 2]), nrm(normal[3 * i], normal[3 * i + 1], normal[3 * i + 2]);
    EXPECT_NEAR(glm::length(t), 1.0f, 1e-5);
    EXPECT_NEAR(glm::dot(t, nrm), 0.0f, 1e-5);
    EXPECT_EQ(std::abs(tangent[4 * i + 3]), 1.0f);
  }
  // Without the skeleton the tree attributes cannot be made.
  p.skeleton = nullptr;
  EXPECT_THROW(encode_mesh(m, MeshFormat::glb, p), InvalidInputError);
  // The file still checks as the same closed mesh.
  p.skeleton = &s;
  EXPECT_TRUE(check_mesh(parse_mesh(glb, MeshFormat::glb, "t")).ok());
}

TEST(Export, GltfKeepsSubMillimetrePrecisionFarFromTheOrigin) {
  // A 5 mm twig in UTM-like coordinates, z ≈ 254 m.
  const dvec3 far(512345.678, 5412345.678, 254.0);
  const Mesh m = test::translated(test::capped_tube({0, 0, 0}, {0.05, 0, 0.3}, 0.005, 12, 6), far);
  const Mesh back = parse_mesh(encode_mesh(m, MeshFormat::glb), MeshFormat::glb, "far.glb");
  ASSERT_EQ(back.positions.size(), m.positions.size());
  // Optimisation reorders vertices; compare each with its nearest original.
  double worst = 0;
  for (const auto& p : back.positions) {
    double best = 1e300;
    for (const auto& q : m.positions) best = std::min(best, glm::length(p - q));
    worst = std::max(worst, best);
  }
  EXPECT_LT(worst, 1e-6);  // float offsets from the box centre: ~1e-8 m here
  EXPECT_TRUE(check_mesh(back).ok());
  // With the input's own origin float32 cannot even tell the vertices apart at 5,000 km.
  const Mesh coarse = parse_mesh(encode_mesh(m, MeshFormat::glb, {.pivot = Pivot::origin}), MeshFormat::glb, "far.glb");
  EXPECT_LT(coarse.positions.size(), m.positions.size());
}

TEST(Export, GltfStoresPositionsOnTheFloatGridExactly) {
  // The meshing stage puts its vertices on core/mesh.h's float grid, so that the .glb holds
  // the very mesh it checked. A twig far from the origin and off-centre in its box: read back,
  // every position is one of the mesh's, bit for bit; off the grid, some are not.
  const dvec3 far(512345.678, 5412345.678, 254.0);
  const Mesh m = test::translated(test::capped_tube({0, 0, 0}, {0.05, 0.01, 0.3}, 0.005, 12, 6), far);
  glm::dvec3 lo(1e300), hi(-1e300);
  for (const auto& p : m.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const glm::dvec3 half = 0.5 * (hi - lo);
  Mesh snapped = m;
  const double grid = float_grid(2.0 * std::max({half.x, half.y, half.z}));
  for (auto& p : snapped.positions) p = snap_to_grid(p, grid);
  auto all_exact = [](const Mesh& mesh, MeshFormat format) {
    std::set<std::array<double, 3>> have;
    for (const auto& p : mesh.positions) have.insert({p.x, p.y, p.z});
    const Mesh back = parse_mesh(encode_mesh(mesh, format), format, "grid");
    for (const auto& p : back.positions) {
      if (!have.count({p.x, p.y, p.z})) return false;
    }
    return !back.positions.empty();
  };
  EXPECT_TRUE(all_exact(snapped, MeshFormat::glb));
  EXPECT_TRUE(all_exact(snapped, MeshFormat::gltf));
  EXPECT_FALSE(all_exact(m, MeshFormat::glb));
}

TEST(Export, NoBranchIdsOrUvsWhenAbsentOrDisabled) {
  Mesh m = test::icosphere(1);
  const Mesh back = parse_mesh(encode_mesh(m, MeshFormat::glb), MeshFormat::glb, "a.glb");
  EXPECT_TRUE(back.corner_uvs.empty());
  EXPECT_TRUE(back.triangle_branch.empty());
  const Mesh tube = test::capped_tube();
  const Mesh bare =
      parse_mesh(encode_mesh(tube, MeshFormat::glb, {.normals = false, .uvs = false, .branch_ids = false}),
                 MeshFormat::glb, "b.glb");
  EXPECT_TRUE(bare.corner_uvs.empty());
  EXPECT_TRUE(bare.triangle_branch.empty());
  EXPECT_TRUE(bare.normals.empty());
  EXPECT_EQ(bare.positions.size(), tube.positions.size());
}

// ---------------------------------------------------------------- atomic writes

TEST(Export, FailedWritesLeaveNoFile) {
  const fs::path dir = test::temp_dir("export_atomic");
  const Mesh m = test::box();
  EXPECT_THROW(write_mesh(m, dir / "missing" / "a.glb"), IoError);
  EXPECT_FALSE(fs::exists(dir / "missing"));
  fs::create_directory(dir / "taken.glb");
  EXPECT_THROW(write_mesh(m, dir / "taken.glb"), IoError);
  EXPECT_TRUE(fs::is_directory(dir / "taken.glb"));
  EXPECT_THROW(write_mesh(m, dir / "a.stl"), InvalidInputError);
  EXPECT_THROW(write_mesh(m, dir / "noext"), InvalidInputError);
  Mesh bad = m;
  bad.triangles.push_back({0, 1, 99});
  EXPECT_THROW(write_mesh(bad, dir / "bad.obj"), InvalidInputError);
  // Only the directory we made is left: no partial or temporary files.
  std::vector<std::string> left;
  for (const auto& e : fs::directory_iterator(dir)) left.push_back(e.path().filename().string());
  EXPECT_EQ(left, std::vector<std::string>{"taken.glb"});
  // An existing file is replaced only by a complete one.
  write_mesh(m, dir / "ok.ply");
  const std::string first = read_file(dir / "ok.ply");
  EXPECT_THROW(write_mesh(bad, dir / "ok.ply"), InvalidInputError);
  EXPECT_EQ(read_file(dir / "ok.ply"), first);
}

TEST(Export, UnknownExtensionNamesTheAcceptedOnes) {
  try {
    mesh_format_from_path("tree.stl");
    FAIL();
  } catch (const InvalidInputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(".stl"), std::string::npos);
    EXPECT_NE(what.find(".glb"), std::string::npos);
    EXPECT_NE(what.find(".ply"), std::string::npos);
  }
  EXPECT_EQ(mesh_format_from_path("A.GLB"), MeshFormat::glb);
  EXPECT_THROW(read_mesh("tree.stl"), InvalidInputError);
  EXPECT_THROW(read_mesh("/nonexistent/tree.glb"), IoError);
}

// ---------------------------------------------------------------- readers: other tools' files

TEST(MeshIo, ObjVariants) {
  const std::string obj =
      "# a unit square pyramid, quads and negative indices, CRLF\r\n"
      "o pyramid\r\nmtllib x.mtl\r\n"
      "v 0 0 0\r\nv 1 0 0 1.0\r\nv 1 1 0 0.5 0.5 0.5\r\nv 0 1 0\r\nv 0.5 0.5 1\r\n"
      "vn 0 0 -1\r\n"
      "usemtl bark\r\ns off\r\n"
      "f 1//1 4//1 3//1 2//1\r\n"
      "f -5 -4 -1\r\nf 2 3 5\r\nf 3 4 5\r\nf 4 1 5\r\n";
  const Mesh m = parse_mesh(obj, MeshFormat::obj, "p.obj");
  EXPECT_EQ(m.positions.size(), 5u);
  EXPECT_EQ(m.triangles.size(), 6u);
  EXPECT_TRUE(m.normals.empty());  // not every corner has one
  EXPECT_TRUE(m.corner_uvs.empty());
  const MeshCheckReport r = check_mesh(m);
  EXPECT_TRUE(r.ok()) << to_text(r);
}

TEST(MeshIo, ObjWeldsDuplicatePositions) {
  // The same square twice over with separate vertices per triangle.
  const std::string obj =
      "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
      "f 1/1 2/2 3/3\nf 4/1 5/3 6/4\n";
  const Mesh m = parse_mesh(obj, MeshFormat::obj, "q.obj");
  EXPECT_EQ(m.positions.size(), 4u);
  EXPECT_EQ(m.triangles, (std::vector<Mesh::Triangle>{{0, 1, 2}, {0, 2, 3}}));
  ASSERT_EQ(m.corner_uvs.size(), 2u);
  EXPECT_EQ(m.corner_uvs[1][2], glm::vec2(0, 1));
  EXPECT_EQ(check_mesh(m).boundary_edges, 4u);
}

TEST(MeshIo, AsciiAndBigEndianPly) {
  const std::string ascii =
      "ply\nformat ascii 1.0\ncomment from another tool\nelement vertex 8\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar red\nelement face 6\nproperty list uchar int vertex_indices\n"
      "element material 1\nproperty float shine\nend_header\n"
      "0 0 0 1\n1 0 0 1\n1 1 0 1\n0 1 0 1\n0 0 1 1\n1 0 1 1\n1 1 1 1\n0 1 1 1\n"
      "4 0 3 2 1\n4 4 5 6 7\n4 0 1 5 4\n4 1 2 6 5\n4 2 3 7 6\n4 3 0 4 7\n0.5\n";
  const Mesh m = parse_mesh(ascii, MeshFormat::ply, "cube.ply");
  EXPECT_EQ(m.positions.size(), 8u);
  EXPECT_EQ(m.triangles.size(), 12u);
  const MeshCheckReport r = check_mesh(m);
  EXPECT_TRUE(r.ok()) << to_text(r);

  // The same tetrahedron-free check for big endian: one triangle with uv per vertex.
  std::string be =
      "ply\nformat binary_big_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
      "property double z\nproperty float u\nproperty float v\nelement face 1\n"
      "property list uchar uint vertex_indices\nend_header\n";
  auto put = [&](auto value) {
    char b[sizeof value];
    std::memcpy(b, &value, sizeof value);
    std::reverse(b, b + sizeof value);
    be.append(b, sizeof value);
  };
  const double xyz[3][3] = {{0, 0, 0}, {2, 0, 0}, {0, 3, 0}};
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) put(xyz[i][k]);
    put(float(i));
    put(float(-i));
  }
  be.push_back(3);
  for (std::uint32_t i = 0; i < 3; ++i) put(i);
  const Mesh t = parse_mesh(be, MeshFormat::ply, "t.ply");
  ASSERT_EQ(t.positions.size(), 3u);
  EXPECT_EQ(t.positions[2], dvec3(0, 3, 0));
  ASSERT_EQ(t.corner_uvs.size(), 1u);
  EXPECT_EQ(t.corner_uvs[0][2], glm::vec2(2, -2));
}

TEST(MeshIo, GltfWithAnExternalBufferAndNodeTransforms) {
  // One triangle in tri.bin beside the .gltf; the node scales by 2 and moves by (1, 0, 0);
  // read y-up (no axis change).
  const fs::path dir = test::temp_dir("gltf_external");
  const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  write_file_atomically(dir / "tri.bin", std::string_view(reinterpret_cast<const char*>(xyz), sizeof xyz));
  const std::string json =
      R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],)"
      R"("nodes":[{"children":[1],"translation":[1,0,0]},{"mesh":0,"scale":[2,2,2]}],)"
      R"("buffers":[{"byteLength":36,"uri":"tri.bin"}],"bufferViews":[{"buffer":0,"byteLength":36}],)"
      R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],)"
      R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]})";
  write_file_atomically(dir / "tri.gltf", json);
  const Mesh m = read_mesh(dir / "tri.gltf", {.up_axis = UpAxis::y});
  ASSERT_EQ(m.positions.size(), 3u);
  EXPECT_EQ(m.positions[1], dvec3(3, 0, 0));
  EXPECT_EQ(m.positions[2], dvec3(1, 2, 0));
  EXPECT_EQ(m.triangles, (std::vector<Mesh::Triangle>{{0, 1, 2}}));
  fs::remove(dir / "tri.bin");
  EXPECT_THROW(read_mesh(dir / "tri.gltf"), InvalidInputError);
}

// ---------------------------------------------------------------- readers: malformed files

struct Malformed {
  const char* name;
  MeshFormat format;
  std::string bytes;
  const char* expect;  // a piece of the message
};

TEST(MeshIo, MalformedFilesAreRejectedWithAMessage) {
  const std::string ply_head =
      "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
      "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  const std::vector<Malformed> cases = {
      {"short_v.obj", MeshFormat::obj, "v 1 2\n", "short_v.obj:1"},
      {"nan_text.obj", MeshFormat::obj, "v 1 2 x\n", "expected a number"},
      {"nonfinite.obj", MeshFormat::obj, "v 1 2 inf\n", "non-finite"},
      {"range.obj", MeshFormat::obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "out of range"},
      {"zero.obj", MeshFormat::obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "out of range"},
      {"two.obj", MeshFormat::obj, "v 0 0 0\nv 1 0 0\nf 1 2\n", "three corners"},
      {"vt.obj", MeshFormat::obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\n", "texture coordinate index"},
      {"slash.obj", MeshFormat::obj, "v 0 0 0\nf 1/1/1/1 1 1\n", "too many"},
      {"empty.ply", MeshFormat::ply, "", "not a PLY file"},
      {"magic.ply", MeshFormat::ply, "plx\n", "not a PLY file"},
      {"noend.ply", MeshFormat::ply, "ply\nformat ascii 1.0\nelement vertex 1\n", "end_header"},
      {"format.ply", MeshFormat::ply, "ply\nformat binary_middle_endian 1.0\nend_header\n", "unknown encoding"},
      {"noformat.ply", MeshFormat::ply, "ply\nelement vertex 0\nend_header\n", "format"},
      {"type.ply", MeshFormat::ply, "ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n",
       "property type"},
      {"noxyz.ply", MeshFormat::ply, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n",
       "x, y or z"},
      {"short.ply", MeshFormat::ply, ply_head + "0 0 0\n1 0 0\n", "truncated"},
      {"huge.ply", MeshFormat::ply,
       "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
       "property float z\nend_header\n",
       "more than the data holds"},
      {"index.ply", MeshFormat::ply, ply_head + "0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n", "out of range"},
      {"negidx.ply", MeshFormat::ply, ply_head + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n", "out of range"},
      {"text.ply", MeshFormat::ply, ply_head + "0 0 zero\n1 0 0\n0 1 0\n3 0 1 2\n", "expected a number"},
      {"face2.ply", MeshFormat::ply, ply_head + "0 0 0\n1 0 0\n0 1 0\n2 0 1\n", "at least three"},
      {"empty.glb", MeshFormat::glb, "", "not a valid glTF"},
      {"garbage.glb", MeshFormat::glb, "this is not a glb file at all", "not a valid glTF"},
      {"empty.gltf", MeshFormat::gltf, "", "not a valid glTF"},
      {"json.gltf", MeshFormat::gltf, "{\"asset\": {\"version\": \"2.0\"", "not a valid glTF"},
      {"noasset.gltf", MeshFormat::gltf, "[1, 2, 3]", "not a valid glTF"},
      {"accessor.gltf", MeshFormat::gltf,
       R"({"asset":{"version":"2.0"},"meshes":[{"primitives":[{"attributes":{"POSITION":5}}]}]})", ""},
      {"bounds.gltf", MeshFormat::gltf,
       R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAA"}],)"
       R"("bufferViews":[{"buffer":0,"byteLength":12}],"accessors":[{"bufferView":0,"componentType":5126,"count":1000,"type":"VEC3"}],)"
       R"("meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}]})",
       ""},
  };
  for (const Malformed& c : cases) {
    SCOPED_TRACE(c.name);
    try {
      (void)parse_mesh(c.bytes, c.format, c.name);
      ADD_FAILURE() << "accepted";
    } catch (const InvalidInputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(c.name), std::string::npos) << what;
      EXPECT_NE(what.find(c.expect), std::string::npos) << what;
    }
  }
}

// Cutting a valid file anywhere must give an InvalidInputError (or, for text formats, a
// smaller valid mesh), never a crash.
TEST(MeshIo, TruncatedFilesNeverCrash) {
  const Mesh m = test::capped_tube({0, 0, 0}, {0, 0, 1}, 0.1, 8, 2, true, 1);
  for (const MeshFormat f : {MeshFormat::glb, MeshFormat::gltf, MeshFormat::obj, MeshFormat::ply}) {
    const std::string bytes = encode_mesh(m, f);
    std::size_t rejected = 0, cuts = 0;
    for (std::size_t cut = 0; cut < bytes.size(); cut += 1 + bytes.size() / 300) {
      ++cuts;
      try {
        const Mesh part = parse_mesh(std::string_view(bytes).substr(0, cut), f, "cut");
        EXPECT_LE(part.triangles.size(), m.triangles.size());
      } catch (const InvalidInputError&) {
        ++rejected;
      }
    }
    if (f != MeshFormat::obj) {
      EXPECT_EQ(rejected, cuts) << int(f);  // binary and structured formats: every cut is an error
    }
  }
}

TEST(MeshIo, GarbageNeverCrashes) {
  std::uint64_t state = 12345;
  auto next = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<char>(state >> 56);
  };
  const std::string good_glb = encode_mesh(test::box(), MeshFormat::glb);
  const std::string good_ply = encode_mesh(test::box(), MeshFormat::ply);
  for (int round = 0; round < 200; ++round) {
    std::string noise(static_cast<std::size_t>(round * 7), ' ');
    for (auto& ch : noise) ch = next();
    // Flip bytes inside valid files too (headers intact, data corrupted).
    std::string glb = good_glb, ply = good_ply;
    for (int k = 0; k < 4; ++k) {
      glb[static_cast<std::size_t>(static_cast<unsigned char>(next())) * glb.size() / 256] = next();
      ply[static_cast<std::size_t>(static_cast<unsigned char>(next())) * ply.size() / 256] = next();
    }
    for (const auto& [bytes, f] : std::vector<std::pair<std::string, MeshFormat>>{
             {noise, MeshFormat::glb},
             {noise, MeshFormat::gltf},
             {noise, MeshFormat::obj},
             {noise, MeshFormat::ply},
             {"ply\nformat binary_little_endian 1.0\n" + noise, MeshFormat::ply},
             {glb, MeshFormat::glb},
             {ply, MeshFormat::ply}}) {
      try {
        (void)parse_mesh(bytes, f, "noise");
      } catch (const InvalidInputError&) {
      }
    }
  }
}

}  // namespace
}  // namespace sm
