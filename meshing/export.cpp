// Mesh writers: glTF 2.0 (tinygltf), OBJ and PLY.
//
// The mesher's output is welded (one vertex per position) with UVs per corner, because the
// checks need the welded topology. File formats store one UV per vertex, so vertices are split
// here, and only where the corners around a vertex really disagree (a UV seam, or a branch
// boundary when `_BRANCH_ID` is written). Everything is done in a fixed order so that the same
// mesh gives the same bytes.

#include "meshing/export.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <sstream>
#include <string_view>

#include <meshoptimizer.h>
#include <tiny_gltf.h>

#include "core/errors.h"
#include "core/file_io.h"

namespace sm {

namespace {

constexpr int kGlArrayBuffer = 34962;
constexpr int kGlElementArrayBuffer = 34963;
// Largest integer a float represents exactly: _BRANCH_ID is a float attribute (glTF forbids
// UNSIGNED_INT vertex attributes, and unsigned short would need padding to 4-byte strides).
constexpr std::uint32_t kMaxExactFloatInt = 1u << 24;

// The key that decides whether two corners of one welded vertex may share an output vertex.
struct CornerKey {
  std::uint32_t u_bits = 0, v_bits = 0, branch = 0;
  friend bool operator==(const CornerKey&, const CornerKey&) = default;
};

void validate_mesh(const Mesh& mesh) {
  const std::size_t nv = mesh.positions.size();
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    for (const std::uint32_t v : mesh.triangles[t]) {
      if (v >= nv) {
        throw InvalidInputError("mesh: triangle " + std::to_string(t) + " references vertex " + std::to_string(v) +
                                " but the mesh has " + std::to_string(nv) + " vertices");
      }
    }
  }
  auto check_size = [](std::size_t got, std::size_t want, const char* what) {
    if (got != 0 && got != want) {
      throw InvalidInputError(std::string("mesh: ") + what + " has " + std::to_string(got) +
                              " entries, expected 0 or " + std::to_string(want));
    }
  };
  check_size(mesh.normals.size(), nv, "normals");
  check_size(mesh.corner_uvs.size(), mesh.triangles.size(), "corner_uvs");
  check_size(mesh.triangle_branch.size(), mesh.triangles.size(), "triangle_branch");
}

// glTF is y-up; a z-up point (x, y, z) becomes (x, z, -y): a rotation by -90° about x, so
// handedness and triangle orientation are preserved.
glm::dvec3 to_y_up(const glm::dvec3& p, UpAxis up) {
  return up == UpAxis::z ? glm::dvec3(p.x, p.z, -p.y) : p;
}

glm::vec3 unit_float(const glm::dvec3& n) {
  const double l = glm::length(n);
  const glm::dvec3 u = (l > 0 && std::isfinite(l)) ? n / l : glm::dvec3(0, 0, 1);
  return glm::vec3(u);
}

// ---------------------------------------------------------------- glTF

template <class T>
std::size_t append_bytes(std::vector<unsigned char>& buf, const std::vector<T>& data) {
  while (buf.size() % 4 != 0) buf.push_back(0);  // every view starts 4-byte aligned
  const std::size_t offset = buf.size();
  const std::size_t bytes = data.size() * sizeof(T);
  buf.resize(offset + bytes);
  if (bytes) std::memcpy(buf.data() + offset, data.data(), bytes);
  return offset;
}

// Adds a buffer view and an accessor for `data` (tightly packed); returns the accessor index.
template <class T>
int add_accessor(tinygltf::Model& model, const std::vector<T>& data, int component_type, int type, int components,
                 int target, bool with_min_max) {
  tinygltf::Buffer& buffer = model.buffers[0];
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = append_bytes(buffer.data, data);
  view.byteLength = data.size() * sizeof(T);
  view.target = target;
  model.bufferViews.push_back(std::move(view));

  tinygltf::Accessor acc;
  acc.bufferView = static_cast<int>(model.bufferViews.size() - 1);
  acc.byteOffset = 0;
  acc.componentType = component_type;
  acc.type = type;
  // Every component type written here (float, uint32) is 4 bytes wide.
  acc.count = data.size() * sizeof(T) / (4 * static_cast<std::size_t>(components));
  if (with_min_max) {
    // The validator compares min/max with the stored float values exactly.
    const auto* f = reinterpret_cast<const float*>(data.data());
    std::vector<double> lo(static_cast<std::size_t>(components), std::numeric_limits<double>::infinity());
    std::vector<double> hi(static_cast<std::size_t>(components), -std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < acc.count; ++i) {
      for (std::size_t c = 0; c < static_cast<std::size_t>(components); ++c) {
        const double x = f[i * static_cast<std::size_t>(components) + c];
        lo[c] = std::min(lo[c], x);
        hi[c] = std::max(hi[c], x);
      }
    }
    acc.minValues = lo;
    acc.maxValues = hi;
  }
  model.accessors.push_back(std::move(acc));
  return static_cast<int>(model.accessors.size() - 1);
}

std::string encode_gltf(const Mesh& mesh, const ExportParams& params, bool binary) {
  const ExportBuffers b = build_export_buffers(mesh, params);
  const std::size_t n = b.positions.size();

  std::vector<glm::dvec3> world(n);
  glm::dvec3 lo(std::numeric_limits<double>::infinity()), hi(-std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < n; ++i) {
    world[i] = to_y_up(b.positions[i], params.up_axis);
    lo = glm::min(lo, world[i]);
    hi = glm::max(hi, world[i]);
  }
  // The origin is kept in double precision in the node translation; the bounding-box centre
  // makes the largest float offset half the extent, whatever the absolute coordinates are.
  const glm::dvec3 origin = (params.recenter && n > 0) ? 0.5 * (lo + hi) : glm::dvec3(0);

  std::vector<glm::vec3> pos(n);
  for (std::size_t i = 0; i < n; ++i) pos[i] = glm::vec3(world[i] - origin);

  tinygltf::Model model;
  model.asset.version = "2.0";
  model.asset.generator = "strandmesh";
  model.buffers.emplace_back();

  tinygltf::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.attributes["POSITION"] =
      add_accessor(model, pos, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 3, kGlArrayBuffer, true);
  if (!b.normals.empty()) {
    std::vector<glm::vec3> nrm(n);
    for (std::size_t i = 0; i < n; ++i) nrm[i] = unit_float(to_y_up(glm::dvec3(b.normals[i]), params.up_axis));
    prim.attributes["NORMAL"] =
        add_accessor(model, nrm, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 3, kGlArrayBuffer, false);
  }
  if (!b.uvs.empty()) {
    prim.attributes["TEXCOORD_0"] =
        add_accessor(model, b.uvs, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, 2, kGlArrayBuffer, false);
  }
  if (!b.branch.empty()) {
    std::vector<float> ids(n);
    for (std::size_t i = 0; i < n; ++i) {
      if (b.branch[i] > kMaxExactFloatInt) {
        throw InvalidInputError("mesh: branch id " + std::to_string(b.branch[i]) +
                                " exceeds 2^24, the largest id _BRANCH_ID (a float attribute) stores exactly; "
                                "export without branch ids");
      }
      ids[i] = static_cast<float>(b.branch[i]);
    }
    prim.attributes["_BRANCH_ID"] =
        add_accessor(model, ids, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR, 1, kGlArrayBuffer, false);
  }
  prim.indices = add_accessor(model, b.indices, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, 1,
                              kGlElementArrayBuffer, false);
  prim.material = 0;

  tinygltf::Material material;
  material.name = "bark";
  material.pbrMetallicRoughness.baseColorFactor = {0.36, 0.25, 0.17, 1.0};
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 0.9;
  model.materials.push_back(std::move(material));

  tinygltf::Mesh gmesh;
  gmesh.name = "tree";
  gmesh.primitives.push_back(std::move(prim));
  model.meshes.push_back(std::move(gmesh));

  tinygltf::Node node;
  node.name = "tree";
  node.mesh = 0;
  if (origin != glm::dvec3(0)) node.translation = {origin.x, origin.y, origin.z};
  model.nodes.push_back(std::move(node));

  tinygltf::Scene scene;
  scene.nodes.push_back(0);
  model.scenes.push_back(std::move(scene));
  model.defaultScene = 0;

  tinygltf::TinyGLTF writer;
  std::ostringstream out;
  if (!writer.WriteGltfSceneToStream(&model, out, /*prettyPrint=*/!binary, /*writeBinary=*/binary) || !out) {
    throw IoError("glTF serialization failed");
  }
  return std::move(out).str();
}

// ---------------------------------------------------------------- OBJ

// Appends a number as `%.9g` would print it, independent of the C locale.
void append_number(std::string& s, double x) {
  char buf[40];
  const auto res = std::to_chars(buf, buf + sizeof buf, x, std::chars_format::general, 9);
  s.append(buf, res.ptr);
}

void append_index(std::string& s, std::uint64_t i) {
  char buf[24];
  const auto res = std::to_chars(buf, buf + sizeof buf, i);
  s.append(buf, res.ptr);
}

const char* axis_name(UpAxis a) {
  return a == UpAxis::z ? "z" : "y";
}

std::string encode_obj(const Mesh& mesh, const ExportParams& params) {
  const ExportBuffers b = build_export_buffers(mesh, params);
  std::string s;
  s.reserve(b.positions.size() * 96 + b.indices.size() * 12 + 128);
  s += "# strandmesh\n# up axis ";
  s += axis_name(params.up_axis);
  s += " (coordinates as in the input, metres)\n";
  for (const auto& p : b.positions) {
    s += "v ";
    append_number(s, p.x);
    s += ' ';
    append_number(s, p.y);
    s += ' ';
    append_number(s, p.z);
    s += '\n';
  }
  for (const auto& t : b.uvs) {
    s += "vt ";
    append_number(s, static_cast<double>(t.x));
    s += ' ';
    append_number(s, static_cast<double>(t.y));
    s += '\n';
  }
  for (const auto& n : b.normals) {
    s += "vn ";
    append_number(s, static_cast<double>(n.x));
    s += ' ';
    append_number(s, static_cast<double>(n.y));
    s += ' ';
    append_number(s, static_cast<double>(n.z));
    s += '\n';
  }
  const bool uv = !b.uvs.empty(), nrm = !b.normals.empty();
  for (std::size_t i = 0; i < b.indices.size(); i += 3) {
    s += 'f';
    for (std::size_t k = 0; k < 3; ++k) {
      const std::uint64_t v = std::uint64_t(b.indices[i + k]) + 1;
      s += ' ';
      append_index(s, v);
      if (uv || nrm) {
        s += '/';
        if (uv) append_index(s, v);
        if (nrm) {
          s += '/';
          append_index(s, v);
        }
      }
    }
    s += '\n';
  }
  return s;
}

// ---------------------------------------------------------------- PLY

template <class T>
void append_le(std::string& s, T value) {
  static_assert(std::is_trivially_copyable_v<T>);
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(bytes, bytes + sizeof(T));
  s.append(bytes, sizeof(T));
}

std::string encode_ply(const Mesh& mesh, const ExportParams& params) {
  const ExportBuffers b = build_export_buffers(mesh, params);
  const bool uv = !b.uvs.empty(), nrm = !b.normals.empty();
  std::string s = "ply\nformat binary_little_endian 1.0\ncomment strandmesh: up axis ";
  s += axis_name(params.up_axis);
  s += ", coordinates as in the input (metres)\nelement vertex " + std::to_string(b.positions.size()) + "\n";
  s += "property double x\nproperty double y\nproperty double z\n";
  if (nrm) s += "property float nx\nproperty float ny\nproperty float nz\n";
  if (uv) s += "property float s\nproperty float t\n";
  s += "element face " + std::to_string(b.indices.size() / 3) + "\n";
  s += "property list uchar uint vertex_indices\nend_header\n";
  const std::size_t vsize = 24 + (nrm ? 12 : 0) + (uv ? 8 : 0);
  s.reserve(s.size() + b.positions.size() * vsize + b.indices.size() / 3 * 13);
  for (std::size_t i = 0; i < b.positions.size(); ++i) {
    append_le(s, b.positions[i].x);
    append_le(s, b.positions[i].y);
    append_le(s, b.positions[i].z);
    if (nrm) {
      append_le(s, b.normals[i].x);
      append_le(s, b.normals[i].y);
      append_le(s, b.normals[i].z);
    }
    if (uv) {
      append_le(s, b.uvs[i].x);
      append_le(s, b.uvs[i].y);
    }
  }
  for (std::size_t i = 0; i < b.indices.size(); i += 3) {
    append_le(s, std::uint8_t{3});
    append_le(s, b.indices[i]);
    append_le(s, b.indices[i + 1]);
    append_le(s, b.indices[i + 2]);
  }
  return s;
}

}  // namespace

ExportBuffers build_export_buffers(const Mesh& mesh, const ExportParams& params) {
  validate_mesh(mesh);
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.triangles.size();
  const bool with_uv = params.uvs && !mesh.corner_uvs.empty();
  const bool with_branch = params.branch_ids && !mesh.triangle_branch.empty();

  // Corners of each welded vertex, in triangle order.
  const VertexCorners vc = vertex_corners(mesh);
  const std::vector<std::uint32_t>& start = vc.begin;
  const std::vector<std::uint32_t>& corners = vc.corner;
  auto key_of = [&](std::uint32_t c) {
    CornerKey key;
    if (with_uv) {
      const glm::vec2 uv = mesh.corner_uvs[c / 3][c % 3];
      key.u_bits = std::bit_cast<std::uint32_t>(uv.x);
      key.v_bits = std::bit_cast<std::uint32_t>(uv.y);
    }
    if (with_branch) key.branch = mesh.triangle_branch[c / 3];
    return key;
  };

  // Distinct keys per vertex, in the order of their first corner; the copies of vertex v are
  // numbered consecutively after those of v-1, so unsplit meshes keep their vertex order.
  std::vector<std::uint32_t> corner_copy(3 * nf);
  std::vector<std::uint32_t> copies(nv, 0);
  std::vector<CornerKey> seen;
  for (std::size_t v = 0; v < nv; ++v) {
    seen.clear();
    for (std::uint32_t i = start[v]; i < start[v + 1]; ++i) {
      const CornerKey key = key_of(corners[i]);
      std::size_t j = 0;
      while (j < seen.size() && !(seen[j] == key)) ++j;
      if (j == seen.size()) seen.push_back(key);
      corner_copy[corners[i]] = static_cast<std::uint32_t>(j);
    }
    copies[v] = static_cast<std::uint32_t>(seen.size());
  }
  std::vector<std::uint64_t> base(nv + 1, 0);
  for (std::size_t v = 0; v < nv; ++v) base[v + 1] = base[v] + copies[v];
  const std::uint64_t out_count = base[nv];
  if (out_count > std::numeric_limits<std::uint32_t>::max()) {
    throw InvalidInputError("mesh: too many vertices after splitting seams for 32-bit indices");
  }

  const std::vector<glm::dvec3> computed =
      (params.normals && mesh.normals.empty()) ? angle_weighted_normals(mesh) : std::vector<glm::dvec3>{};
  const std::vector<glm::dvec3>& normals = mesh.normals.empty() ? computed : mesh.normals;

  ExportBuffers b;
  b.positions.resize(out_count);
  b.source_vertex.resize(out_count);
  if (params.normals) b.normals.resize(out_count);
  if (with_uv) b.uvs.resize(out_count);
  if (with_branch) b.branch.resize(out_count);
  b.indices.resize(3 * nf);
  for (std::size_t c = 0; c < 3 * nf; ++c) {
    const std::uint32_t v = mesh.triangles[c / 3][c % 3];
    const auto out = static_cast<std::uint32_t>(base[v] + corner_copy[c]);
    b.indices[c] = out;
    b.positions[out] = mesh.positions[v];
    b.source_vertex[out] = v;
    if (params.normals) b.normals[out] = unit_float(normals[v]);
    if (with_uv) b.uvs[out] = mesh.corner_uvs[c / 3][c % 3];
    if (with_branch) b.branch[out] = mesh.triangle_branch[c / 3];
  }

  if (params.optimize && nf > 0) {
    // Vertex cache order for the triangles, then vertices in first-use order (both
    // deterministic functions of the index buffer). The FIFO variant: our strips are local
    // already, and on them it matches the full optimizer (ACMR 0.695 vs 0.696 at cache size
    // 16 on a grown tree) at a fraction of its time (3.3 M triangles: about 0.4 vs 1.2 s).
    std::vector<unsigned int> reordered(b.indices.size());
    meshopt_optimizeVertexCacheFifo(reordered.data(), b.indices.data(), b.indices.size(), out_count, 16);
    std::vector<unsigned int> remap(out_count);
    meshopt_optimizeVertexFetchRemap(remap.data(), reordered.data(), reordered.size(), out_count);
    meshopt_remapIndexBuffer(b.indices.data(), reordered.data(), reordered.size(), remap.data());
    auto apply = [&](auto& vec) {
      if (vec.empty()) return;
      auto copy = vec;
      for (std::size_t i = 0; i < out_count; ++i) vec[remap[i]] = copy[i];
    };
    apply(b.positions);
    apply(b.normals);
    apply(b.uvs);
    apply(b.branch);
    apply(b.source_vertex);
  }
  return b;
}

MeshFormat mesh_format_from_path(const std::filesystem::path& path) {
  const std::string ext = extension_of(path);
  if (ext == "glb") return MeshFormat::glb;
  if (ext == "gltf") return MeshFormat::gltf;
  if (ext == "obj") return MeshFormat::obj;
  if (ext == "ply") return MeshFormat::ply;
  throw InvalidInputError(path.string() + ": unknown mesh format '" +
                          (ext.empty() ? std::string("(no extension)") : "." + ext) +
                          "'; accepted extensions are .glb, .gltf, .obj and .ply");
}

std::string encode_mesh(const Mesh& mesh, MeshFormat format, const ExportParams& params) {
  ExportParams p = params;
  switch (format) {
    case MeshFormat::glb:
      return encode_gltf(mesh, p, true);
    case MeshFormat::gltf:
      return encode_gltf(mesh, p, false);
    case MeshFormat::obj:
      p.branch_ids = false;  // not stored in OBJ: no reason to split at branch boundaries
      return encode_obj(mesh, p);
    case MeshFormat::ply:
      p.branch_ids = false;
      return encode_ply(mesh, p);
  }
  throw InternalError("encode_mesh: unknown format");
}

void write_mesh(const Mesh& mesh, const std::filesystem::path& path, const ExportParams& params) {
  const MeshFormat format = mesh_format_from_path(path);
  std::string bytes;
  try {
    bytes = encode_mesh(mesh, format, params);
  } catch (const InvalidInputError& e) {
    throw InvalidInputError(path.string() + ": " + e.what());
  }
  write_file_atomically(path, bytes);
}

}  // namespace sm
