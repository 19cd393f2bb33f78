// Mesh readers: glTF 2.0 (tinygltf), OBJ and PLY, welding split vertices back together.
//
// The readers exist so that `strandmesh check` can judge any mesh file, ours or another
// tool's, and so that tests can round-trip the writers. Every count and offset read from a
// file is checked against the data that is actually there before anything is allocated or
// indexed, so truncated or hostile files end in an InvalidInputError, never a crash.

#include "meshio/mesh_io.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <optional>
#include <unordered_map>
#include <vector>

#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <meshoptimizer.h>
#include <nlohmann/json.hpp>
#include <tiny_gltf.h>

#include "core/errors.h"
#include "core/file_io.h"
#include "core/input_limits.h"
#include "core/math.h"
#include "meshio/placement.h"

namespace sm {

namespace {

// ---------------------------------------------------------------- welding

struct PositionKey {
  std::array<std::uint64_t, 3> bits;
  friend bool operator==(const PositionKey&, const PositionKey&) = default;
};

struct PositionKeyHash {
  std::size_t operator()(const PositionKey& k) const noexcept {
    std::uint64_t h = 0x9e3779b97f4a7c15ull;
    for (const std::uint64_t b : k.bits) {
      h ^= b + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
      h *= 0xbf58476d1ce4e5b9ull;
    }
    return static_cast<std::size_t>(h ^ (h >> 31));
  }
};

// Collects vertices (welded by exact position) and triangles, then builds the Mesh.
class MeshAssembler {
 public:
  explicit MeshAssembler(std::string name) : name_(std::move(name)) {}

  // Adds a file vertex and returns the welded vertex it maps to.
  std::uint32_t add_vertex(const glm::dvec3& p, std::string_view where) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      throw InvalidInputError(name_ + ": " + std::string(where) + ": non-finite vertex coordinate");
    }
    // Beyond float32's range no mesh format we write can hold it, and the checks' squared
    // distances would overflow to infinity (a mesh 1e200 m away gave "fidelity p95 inf").
    constexpr double kMax = double(std::numeric_limits<float>::max());
    if (std::abs(p.x) > kMax || std::abs(p.y) > kMax || std::abs(p.z) > kMax) {
      throw InvalidInputError(name_ + ": " + std::string(where) +
                              ": vertex coordinate beyond float32's range (3.4e38 m)");
    }
    const glm::dvec3 q = p + glm::dvec3(0.0);  // -0 + 0 = +0: both zeros weld
    const PositionKey key{
        {std::bit_cast<std::uint64_t>(q.x), std::bit_cast<std::uint64_t>(q.y), std::bit_cast<std::uint64_t>(q.z)}};
    const auto [it, inserted] = index_.try_emplace(key, static_cast<std::uint32_t>(mesh_.positions.size()));
    if (inserted) {
      if (mesh_.positions.size() >= std::numeric_limits<std::uint32_t>::max()) {
        throw InvalidInputError(name_ + ": too many vertices for 32-bit indices");
      }
      mesh_.positions.push_back(q);
      normal_.emplace_back(0.0);
      has_normal_.push_back(0);
    }
    return it->second;
  }

  // Gives welded vertex v the normal n unless an earlier copy already gave it one.
  void offer_normal(std::uint32_t v, const glm::dvec3& n) {
    if (!has_normal_[v]) {
      normal_[v] = n;
      has_normal_[v] = 1;
    }
  }
  void corner_without_normal() { normals_complete_ = false; }

  // `normals`: the file's normal at each corner (its vertex copy's), when it has normals.
  void add_triangle(const Mesh::Triangle& t, const std::array<glm::vec2, 3>* uvs, std::optional<std::uint32_t> branch,
                    const std::array<glm::dvec3, 3>* normals) {
    mesh_.triangles.push_back(t);
    if (normals) {
      corner_normal_.push_back(*normals);
    } else {
      corner_normals_complete_ = false;
    }
    if (uvs) {
      uvs_.push_back(*uvs);
    } else {
      uvs_complete_ = false;
    }
    if (branch) {
      branch_.push_back(*branch);
    } else {
      branch_complete_ = false;
    }
  }

  [[nodiscard]] std::size_t vertex_count() const { return mesh_.positions.size(); }

  Mesh finish() {
    // (An empty file is malformed input, exit 1, not a mesh that fails its checks.)
    if (mesh_.triangles.empty()) throw InvalidInputError(name_ + ": no triangles (the file holds no mesh)");
    Mesh m = std::move(mesh_);
    if (uvs_complete_ && !m.triangles.empty()) m.corner_uvs = std::move(uvs_);
    if (branch_complete_ && !m.triangles.empty()) m.triangle_branch = std::move(branch_);
    bool all = normals_complete_ && !m.triangles.empty();
    std::vector<std::uint8_t> used(m.positions.size(), 0);
    for (const auto& t : m.triangles) {
      for (const std::uint32_t v : t) used[v] = 1;
    }
    for (std::size_t v = 0; v < m.positions.size() && all; ++v) all = !used[v] || has_normal_[v];
    auto unit = [](const glm::dvec3& n) { return normalize_or(n, glm::dvec3(0, 0, 1)); };
    if (all) {
      m.normals.resize(m.positions.size());
      for (std::size_t v = 0; v < m.positions.size(); ++v) m.normals[v] = has_normal_[v] ? unit(normal_[v]) : glm::dvec3(0, 0, 1);
    }
    // Copies of a vertex with different normals (smoothing groups): per-corner normals.
    bool split = false;
    if (all && corner_normals_complete_ && corner_normal_.size() == m.triangles.size()) {
      for (std::size_t f = 0; f < m.triangles.size() && !split; ++f) {
        for (std::size_t k = 0; k < 3; ++k) split = split || corner_normal_[f][k] != normal_[m.triangles[f][k]];
      }
    }
    if (split) {
      m.corner_normals.resize(m.triangles.size());
      for (std::size_t f = 0; f < m.triangles.size(); ++f) {
        for (std::size_t k = 0; k < 3; ++k) m.corner_normals[f][k] = glm::vec3(unit(corner_normal_[f][k]));
      }
    }
    return m;
  }

 private:
  std::string name_;
  Mesh mesh_;
  std::unordered_map<PositionKey, std::uint32_t, PositionKeyHash> index_;
  std::vector<glm::dvec3> normal_;
  std::vector<std::uint8_t> has_normal_;
  std::vector<std::array<glm::vec2, 3>> uvs_;
  std::vector<std::array<glm::dvec3, 3>> corner_normal_;
  std::vector<std::uint32_t> branch_;
  bool normals_complete_ = true, uvs_complete_ = true, branch_complete_ = true, corner_normals_complete_ = true;
};

// ---------------------------------------------------------------- text helpers

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\f' || c == '\v';
}

// Splits a line into whitespace-separated tokens (no allocation of the strings themselves).
void tokenize(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t b = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > b) out.push_back(line.substr(b, i - b));
  }
}

std::optional<double> parse_double(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double x = 0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), x);
  if (res.ec != std::errc() || res.ptr != s.data() + s.size()) return std::nullopt;
  return x;
}

std::optional<std::int64_t> parse_int(std::string_view s) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  std::int64_t x = 0;
  const auto res = std::from_chars(s.data(), s.data() + s.size(), x);
  if (res.ec != std::errc() || res.ptr != s.data() + s.size()) return std::nullopt;
  return x;
}

std::string quoted(std::string_view s) {
  constexpr std::size_t kMax = 40;
  std::string r = "'";
  r += s.size() > kMax ? std::string(s.substr(0, kMax)) + "..." : std::string(s);
  return r + "'";
}

// ---------------------------------------------------------------- OBJ

Mesh parse_obj(std::string_view text, const std::string& name) {
  MeshAssembler out(name);
  std::vector<std::uint32_t> welded;  // OBJ vertex index → welded vertex
  std::vector<glm::vec2> texcoords;
  std::vector<glm::dvec3> normals;
  std::vector<std::string_view> tok;
  std::vector<std::uint32_t> poly_v;
  std::vector<std::int64_t> poly_t, poly_n;
  std::size_t line_no = 0, pos = 0;

  while (pos < text.size()) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    tokenize(line, tok);
    if (tok.empty()) continue;
    const std::string where = "line " + std::to_string(line_no);
    auto fail = [&](const std::string& what) -> void {
      throw InvalidInputError(name + ":" + std::to_string(line_no) + ": " + what);
    };
    auto number = [&](std::size_t i) {
      const auto x = parse_double(tok[i]);
      if (!x) fail("expected a number, found " + quoted(tok[i]));
      return *x;
    };
    const std::string_view key = tok[0];
    if (key == "v") {
      if (tok.size() < 4) fail("'v' needs three coordinates");
      welded.push_back(out.add_vertex({number(1), number(2), number(3)}, where));
    } else if (key == "vt") {
      if (tok.size() < 2) fail("'vt' needs at least one coordinate");
      texcoords.emplace_back(static_cast<float>(number(1)), tok.size() > 2 ? static_cast<float>(number(2)) : 0.0f);
    } else if (key == "vn") {
      if (tok.size() < 4) fail("'vn' needs three coordinates");
      normals.emplace_back(number(1), number(2), number(3));
    } else if (key == "f") {
      if (tok.size() < 4) fail("a face needs at least three corners, found " + std::to_string(tok.size() - 1));
      poly_v.clear();
      poly_t.clear();
      poly_n.clear();
      for (std::size_t i = 1; i < tok.size(); ++i) {
        // v, v/vt, v//vn or v/vt/vn; indices are 1-based, negative ones count from the end.
        std::array<std::string_view, 3> part{};
        std::string_view rest = tok[i];
        for (std::size_t k = 0; k < 3; ++k) {
          const std::size_t slash = rest.find('/');
          part[k] = rest.substr(0, slash);
          if (slash == std::string_view::npos) break;
          rest = rest.substr(slash + 1);
          if (k == 2) fail("corner " + quoted(tok[i]) + " has too many '/'");
        }
        auto resolve = [&](std::string_view s, std::size_t count, const char* what) -> std::int64_t {
          if (s.empty()) return -1;
          const auto idx = parse_int(s);
          if (!idx) fail(std::string("bad ") + what + " index " + quoted(s) + " in corner " + quoted(tok[i]));
          const auto n = static_cast<std::int64_t>(count);
          const std::int64_t r = *idx > 0 ? *idx - 1 : n + *idx;
          if (*idx == 0 || r < 0 || r >= n) {
            fail(std::string(what) + " index " + std::to_string(*idx) + " is out of range (" + std::to_string(count) +
                 " " + what + "s defined so far)");
          }
          return r;
        };
        if (part[0].empty()) fail("corner " + quoted(tok[i]) + " has no vertex index");
        poly_v.push_back(welded[static_cast<std::size_t>(resolve(part[0], welded.size(), "vertex"))]);
        poly_t.push_back(resolve(part[1], texcoords.size(), "texture coordinate"));
        poly_n.push_back(resolve(part[2], normals.size(), "normal"));
      }
      for (std::size_t k = 0; k < poly_v.size(); ++k) {
        if (poly_n[k] >= 0) {
          out.offer_normal(poly_v[k], normals[static_cast<std::size_t>(poly_n[k])]);
        } else {
          out.corner_without_normal();
        }
      }
      const bool has_uv = std::all_of(poly_t.begin(), poly_t.end(), [](std::int64_t t) { return t >= 0; });
      const bool has_n = std::all_of(poly_n.begin(), poly_n.end(), [](std::int64_t n) { return n >= 0; });
      for (std::size_t k = 1; k + 1 < poly_v.size(); ++k) {  // fan around the first corner
        const std::array<std::size_t, 3> c{0, k, k + 1};
        std::array<glm::vec2, 3> uv{};
        std::array<glm::dvec3, 3> nrm{};
        for (std::size_t j = 0; j < 3; ++j) {
          if (has_uv) uv[j] = texcoords[static_cast<std::size_t>(poly_t[c[j]])];
          if (has_n) nrm[j] = normals[static_cast<std::size_t>(poly_n[c[j]])];
        }
        out.add_triangle({poly_v[c[0]], poly_v[c[1]], poly_v[c[2]]}, has_uv ? &uv : nullptr, std::nullopt,
                         has_n ? &nrm : nullptr);
      }
    }
    // Anything else (o, g, s, usemtl, mtllib, l, p, vp, ...) carries nothing we keep.
  }
  return out.finish();
}

// ---------------------------------------------------------------- PLY

enum class PlyType { i8, u8, i16, u16, i32, u32, f32, f64 };

std::optional<PlyType> ply_type(std::string_view s) {
  if (s == "char" || s == "int8") return PlyType::i8;
  if (s == "uchar" || s == "uint8") return PlyType::u8;
  if (s == "short" || s == "int16") return PlyType::i16;
  if (s == "ushort" || s == "uint16") return PlyType::u16;
  if (s == "int" || s == "int32") return PlyType::i32;
  if (s == "uint" || s == "uint32") return PlyType::u32;
  if (s == "float" || s == "float32") return PlyType::f32;
  if (s == "double" || s == "float64") return PlyType::f64;
  return std::nullopt;
}

std::size_t ply_size(PlyType t) {
  switch (t) {
    case PlyType::i8:
    case PlyType::u8:
      return 1;
    case PlyType::i16:
    case PlyType::u16:
      return 2;
    case PlyType::i32:
    case PlyType::u32:
    case PlyType::f32:
      return 4;
    case PlyType::f64:
      return 8;
  }
  return 1;
}

bool ply_is_integer(PlyType t) {
  return t != PlyType::f32 && t != PlyType::f64;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::f32;
  bool is_list = false;
  PlyType count_type = PlyType::u8;
};

struct PlyElement {
  std::string name;
  std::uint64_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { ascii, binary_le, binary_be };

// Reads the values of the data section, ascii or binary, with bounds checks.
class PlyData {
 public:
  PlyData(std::string_view data, PlyFormat format, const std::string& name)
      : data_(data), format_(format), name_(name) {}

  double scalar(PlyType t) {
    if (format_ == PlyFormat::ascii) {
      const std::string_view tok = next_token();
      if (ply_is_integer(t)) {
        const auto v = parse_int(tok);
        if (!v) fail("expected an integer, found " + quoted(tok));
        return static_cast<double>(*v);
      }
      const auto v = parse_double(tok);
      if (!v) fail("expected a number, found " + quoted(tok));
      return *v;
    }
    const std::size_t n = ply_size(t);
    if (data_.size() - pos_ < n) fail("unexpected end of data (file truncated?)");
    unsigned char b[8];
    std::memcpy(b, data_.data() + pos_, n);
    pos_ += n;
    const bool swap = (format_ == PlyFormat::binary_be) != (std::endian::native == std::endian::big);
    if (swap) std::reverse(b, b + n);
    switch (t) {
      case PlyType::i8:
        return static_cast<double>(static_cast<std::int8_t>(b[0]));
      case PlyType::u8:
        return static_cast<double>(b[0]);
      case PlyType::i16:
        return static_cast<double>(load<std::int16_t>(b));
      case PlyType::u16:
        return static_cast<double>(load<std::uint16_t>(b));
      case PlyType::i32:
        return static_cast<double>(load<std::int32_t>(b));
      case PlyType::u32:
        return static_cast<double>(load<std::uint32_t>(b));
      case PlyType::f32:
        return static_cast<double>(load<float>(b));
      case PlyType::f64:
        return load<double>(b);
    }
    return 0;
  }

  // A list count: a non-negative integer.
  std::uint64_t count(PlyType t) {
    const double c = scalar(t);
    if (!(c >= 0) || c != std::floor(c)) fail("invalid list length " + std::to_string(c));
    return static_cast<std::uint64_t>(c);
  }

  // Bytes (binary) or characters (ascii) not yet read.
  [[nodiscard]] std::size_t remaining() const { return data_.size() - pos_; }

  void set_context(std::string ctx) { context_ = std::move(ctx); }

  [[noreturn]] void fail(const std::string& what) const {
    throw InvalidInputError(name_ + ": " + (context_.empty() ? "" : context_ + ": ") + what);
  }

 private:
  template <class T>
  static T load(const unsigned char* b) {
    T v;
    std::memcpy(&v, b, sizeof(T));
    return v;
  }

  std::string_view next_token() {
    while (pos_ < data_.size() && (is_space(data_[pos_]) || data_[pos_] == '\n')) ++pos_;
    const std::size_t b = pos_;
    while (pos_ < data_.size() && !is_space(data_[pos_]) && data_[pos_] != '\n') ++pos_;
    if (pos_ == b) fail("unexpected end of data (file truncated?)");
    return data_.substr(b, pos_ - b);
  }

  std::string_view data_;
  PlyFormat format_;
  const std::string& name_;
  std::size_t pos_ = 0;
  std::string context_;
};

Mesh parse_ply(std::string_view bytes, const std::string& name) {
  auto fail = [&](const std::string& what) -> void { throw InvalidInputError(name + ": " + what); };
  if (bytes.substr(0, 3) != "ply" || bytes.size() < 4 || (bytes[3] != '\n' && bytes[3] != '\r')) {
    fail("not a PLY file (it must start with 'ply')");
  }
  // Header: lines up to and including "end_header".
  std::vector<PlyElement> elements;
  std::optional<PlyFormat> format;
  std::size_t pos = 0, line_no = 0;
  std::vector<std::string_view> tok;
  bool ended = false;
  while (!ended) {
    const std::size_t end = bytes.find('\n', pos);
    if (end == std::string_view::npos) fail("header has no 'end_header' line");
    const std::string_view line = bytes.substr(pos, end - pos);
    pos = end + 1;
    ++line_no;
    tokenize(line, tok);
    const std::string at = "header line " + std::to_string(line_no) + ": ";
    if (tok.empty() || tok[0] == "comment" || tok[0] == "obj_info" || (line_no == 1 && tok[0] == "ply")) continue;
    if (tok[0] == "format") {
      if (tok.size() != 3 || tok[2] != "1.0") fail(at + "expected 'format <encoding> 1.0'");
      if (tok[1] == "ascii")
        format = PlyFormat::ascii;
      else if (tok[1] == "binary_little_endian")
        format = PlyFormat::binary_le;
      else if (tok[1] == "binary_big_endian")
        format = PlyFormat::binary_be;
      else
        fail(at + "unknown encoding " + quoted(tok[1]));
    } else if (tok[0] == "element") {
      const auto n = tok.size() == 3 ? parse_int(tok[2]) : std::nullopt;
      if (!n || *n < 0) fail(at + "expected 'element <name> <count>'");
      elements.push_back({std::string(tok[1]), static_cast<std::uint64_t>(*n), {}});
    } else if (tok[0] == "property") {
      if (elements.empty()) fail(at + "property before any element");
      PlyProperty p;
      if (tok.size() == 5 && tok[1] == "list") {
        const auto ct = ply_type(tok[2]), it = ply_type(tok[3]);
        if (!ct || !it || !ply_is_integer(*ct)) fail(at + "invalid list property types");
        p = {std::string(tok[4]), *it, true, *ct};
      } else if (tok.size() == 3) {
        const auto t = ply_type(tok[1]);
        if (!t) fail(at + "unknown property type " + quoted(tok[1]));
        p = {std::string(tok[2]), *t, false, PlyType::u8};
      } else {
        fail(at + "expected 'property <type> <name>' or 'property list <count type> <type> <name>'");
      }
      elements.back().properties.push_back(std::move(p));
    } else if (tok[0] == "end_header") {
      ended = true;
    } else {
      fail(at + "unexpected " + quoted(tok[0]));
    }
  }
  if (!format) fail("header has no 'format' line");

  PlyData data(bytes.substr(pos), *format, name);
  MeshAssembler out(name);
  std::vector<std::uint32_t> welded;  // PLY vertex index → welded vertex
  std::vector<glm::vec2> vertex_uv;
  std::vector<glm::dvec3> vertex_normal;  // PLY vertex index → its normal
  bool saw_vertex = false;
  bool vertex_normals = false, vertex_uvs = false;
  std::vector<std::size_t> poly_file;  // the PLY vertex indices of one face
  std::vector<glm::vec2> poly_uv;

  for (const PlyElement& el : elements) {
    // Every element needs at least one byte (binary) or two characters (ascii) per property;
    // check the count against the data before allocating anything for it.
    std::size_t min_size = 0;
    for (const PlyProperty& p : el.properties) {
      min_size += *format == PlyFormat::ascii ? 2 : ply_size(p.is_list ? p.count_type : p.type);
    }
    if (min_size > 0 && el.count > data.remaining() / min_size + 1) {
      data.fail("element '" + el.name + "' declares " + std::to_string(el.count) +
                " entries, more than the data holds (file truncated?)");
    }
    const bool is_vertex = el.name == "vertex", is_face = el.name == "face";
    if (el.properties.empty()) continue;  // nothing to read, whatever the count says
    if (is_vertex) {
      if (saw_vertex) data.fail("more than one 'vertex' element");
      saw_vertex = true;
      if (el.count > std::numeric_limits<std::uint32_t>::max()) data.fail("too many vertices");
    }
    if (is_face && !saw_vertex) data.fail("'face' element before the 'vertex' element");
    int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, iu = -1, iv = -1, iface = -1, itex = -1;
    for (std::size_t k = 0; k < el.properties.size(); ++k) {
      const std::string& n = el.properties[k].name;
      const int ki = static_cast<int>(k);
      const bool list = el.properties[k].is_list;
      if (is_vertex && !list) {
        if (n == "x")
          ix = ki;
        else if (n == "y")
          iy = ki;
        else if (n == "z")
          iz = ki;
        else if (n == "nx")
          inx = ki;
        else if (n == "ny")
          iny = ki;
        else if (n == "nz")
          inz = ki;
        else if (n == "s" || n == "u" || n == "texture_u" || n == "texture_s")
          iu = ki;
        else if (n == "t" || n == "v" || n == "texture_v" || n == "texture_t")
          iv = ki;
      }
      if (is_face && list && (n == "vertex_indices" || n == "vertex_index")) iface = ki;
      if (is_face && list && n == "texcoord") itex = ki;
    }
    if (is_vertex && (ix < 0 || iy < 0 || iz < 0)) data.fail("the 'vertex' element lacks x, y or z");
    if (is_face && iface < 0) data.fail("the 'face' element has no 'vertex_indices' list");
    const bool has_normal = inx >= 0 && iny >= 0 && inz >= 0;
    const bool has_uv = iu >= 0 && iv >= 0;
    if (is_vertex) {
      vertex_normals = has_normal;
      vertex_uvs = has_uv;
      welded.reserve(static_cast<std::size_t>(el.count));
      if (has_uv) vertex_uv.reserve(static_cast<std::size_t>(el.count));
      if (has_normal) vertex_normal.reserve(static_cast<std::size_t>(el.count));
    }

    std::array<double, 8> v{};
    for (std::uint64_t i = 0; i < el.count; ++i) {
      data.set_context(el.name + " " + std::to_string(i));
      poly_file.clear();
      poly_uv.clear();
      for (std::size_t k = 0; k < el.properties.size(); ++k) {
        const PlyProperty& p = el.properties[k];
        const int ki = static_cast<int>(k);
        if (!p.is_list) {
          const double x = data.scalar(p.type);
          if (is_vertex) {
            if (ki == ix) v[0] = x;
            if (ki == iy) v[1] = x;
            if (ki == iz) v[2] = x;
            if (ki == inx) v[3] = x;
            if (ki == iny) v[4] = x;
            if (ki == inz) v[5] = x;
            if (ki == iu) v[6] = x;
            if (ki == iv) v[7] = x;
          }
          continue;
        }
        const std::uint64_t n = data.count(p.count_type);
        if (n > data.remaining()) data.fail("list of " + std::to_string(n) + " entries runs past the end of the data");
        for (std::uint64_t j = 0; j < n; ++j) {
          const double x = data.scalar(p.type);
          if (is_face && ki == iface) {
            if (!(x >= 0) || x >= static_cast<double>(welded.size()) || x != std::floor(x)) {
              data.fail("vertex index " + std::to_string(x) + " is out of range (" + std::to_string(welded.size()) +
                        " vertices)");
            }
            poly_file.push_back(static_cast<std::size_t>(x));
          } else if (is_face && ki == itex) {
            if (j % 2 == 0)
              poly_uv.emplace_back(static_cast<float>(x), 0.0f);
            else
              poly_uv.back().y = static_cast<float>(x);
          }
        }
      }
      if (is_vertex) {
        const std::uint32_t w = out.add_vertex({v[0], v[1], v[2]}, "vertex " + std::to_string(i));
        welded.push_back(w);
        if (has_normal) {
          out.offer_normal(w, {v[3], v[4], v[5]});
          vertex_normal.emplace_back(v[3], v[4], v[5]);
        }
        if (has_uv) vertex_uv.emplace_back(static_cast<float>(v[6]), static_cast<float>(v[7]));
      } else if (is_face) {
        if (poly_file.size() < 3) {
          data.fail("a face needs at least three vertices, found " + std::to_string(poly_file.size()));
        }
        if (!vertex_normals) out.corner_without_normal();
        const bool corner_uv = itex >= 0 && poly_uv.size() == poly_file.size();
        for (std::size_t k = 1; k + 1 < poly_file.size(); ++k) {  // fan around the first corner
          const std::array<std::size_t, 3> c{0, k, k + 1};
          std::array<glm::vec2, 3> uv{};
          std::array<glm::dvec3, 3> nrm{};
          for (std::size_t j = 0; j < 3; ++j) {
            uv[j] = corner_uv ? poly_uv[c[j]] : vertex_uvs ? vertex_uv[poly_file[c[j]]] : glm::vec2(0);
            if (vertex_normals) nrm[j] = vertex_normal[poly_file[c[j]]];
          }
          out.add_triangle({welded[poly_file[0]], welded[poly_file[k]], welded[poly_file[k + 1]]},
                           corner_uv || vertex_uvs ? &uv : nullptr, std::nullopt, vertex_normals ? &nrm : nullptr);
        }
      }
    }
  }
  data.set_context({});
  return out.finish();
}

// ---------------------------------------------------------------- glTF

// Images are irrelevant to a mesh check; skip decoding them (and stb_image's attack surface).
bool ignore_image(tinygltf::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;
}

// Reads accessor `index` as #count × `components` doubles, checking every offset and length
// against the buffer. `allowed` lists the component types accepted for this use.
class AccessorReader {
 public:
  AccessorReader(const tinygltf::Model& model, const std::string& name) : model_(model), name_(name) {}

  std::vector<double> read(int index, int type, std::initializer_list<int> allowed, const std::string& what) const {
    if (index < 0 || static_cast<std::size_t>(index) >= model_.accessors.size()) {
      fail(what + ": accessor " + std::to_string(index) + " does not exist");
    }
    const tinygltf::Accessor& acc = model_.accessors[static_cast<std::size_t>(index)];
    const std::string where = what + " (accessor " + std::to_string(index) + ")";
    if (acc.sparse.isSparse) fail(where + ": sparse accessors are not supported");
    if (acc.type != type) fail(where + ": unexpected accessor type");
    if (std::find(allowed.begin(), allowed.end(), acc.componentType) == allowed.end()) {
      fail(where + ": unsupported component type " + std::to_string(acc.componentType));
    }
    const auto components =
        static_cast<std::size_t>(tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(acc.type)));
    const auto csize =
        static_cast<std::size_t>(tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(acc.componentType)));
    const std::size_t count = acc.count;
    std::vector<double> out;
    if (count == 0) return out;
    if (acc.bufferView < 0) fail(where + ": no buffer view (all-zero accessors are not supported)");
    if (static_cast<std::size_t>(acc.bufferView) >= model_.bufferViews.size())
      fail(where + ": buffer view does not exist");
    const tinygltf::BufferView& view = model_.bufferViews[static_cast<std::size_t>(acc.bufferView)];
    if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model_.buffers.size())
      fail(where + ": buffer does not exist");
    const std::vector<unsigned char>& data = model_.buffers[static_cast<std::size_t>(view.buffer)].data;
    const std::size_t elem = components * csize;
    const std::size_t stride = view.byteStride ? view.byteStride : elem;
    if (stride < elem) fail(where + ": byte stride smaller than an element");
    // Overflow-safe bounds: the view must lie in the buffer, the accessor in the view.
    if (view.byteOffset > data.size() || view.byteLength > data.size() - view.byteOffset) {
      fail(where + ": buffer view exceeds its buffer (" + std::to_string(data.size()) + " bytes)");
    }
    if (acc.byteOffset > view.byteLength) fail(where + ": byte offset beyond its buffer view");
    const std::size_t room = view.byteLength - acc.byteOffset;
    if (elem > room || (count - 1) > (room - elem) / stride) {
      fail(where + ": " + std::to_string(count) + " elements exceed the buffer view (" +
           std::to_string(view.byteLength) + " bytes)");
    }
    const unsigned char* base = data.data() + view.byteOffset + acc.byteOffset;
    out.resize(count * components);
    for (std::size_t i = 0; i < count; ++i) {
      const unsigned char* e = base + i * stride;
      for (std::size_t c = 0; c < components; ++c) {
        out[i * components + c] = component(e + c * csize, acc.componentType, acc.normalized);
      }
    }
    return out;
  }

 private:
  static double component(const unsigned char* p, int type, bool normalized) {
    switch (type) {
      case TINYGLTF_COMPONENT_TYPE_FLOAT:
        return static_cast<double>(load<float>(p));
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return normalized ? p[0] / 255.0 : p[0];
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        const double v = load<std::uint16_t>(p);
        return normalized ? v / 65535.0 : v;
      }
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT:
        return static_cast<double>(load<std::uint32_t>(p));
      case TINYGLTF_COMPONENT_TYPE_BYTE: {  // KHR_mesh_quantization
        const double v = static_cast<std::int8_t>(p[0]);
        return normalized ? std::max(v / 127.0, -1.0) : v;
      }
      case TINYGLTF_COMPONENT_TYPE_SHORT: {
        const double v = load<std::int16_t>(p);
        return normalized ? std::max(v / 32767.0, -1.0) : v;
      }
      default:
        return 0;
    }
  }
  template <class T>
  static T load(const unsigned char* p) {
    T v;
    std::memcpy(&v, p, sizeof(T));
    if constexpr (std::endian::native == std::endian::big) {
      auto* b = reinterpret_cast<unsigned char*>(&v);
      std::reverse(b, b + sizeof(T));
    }
    return v;
  }
  [[noreturn]] void fail(const std::string& what) const { throw InvalidInputError(name_ + ": " + what); }

  const tinygltf::Model& model_;
  const std::string& name_;
};

// External buffers (a .gltf's `uri` naming a file) are read only from the glTF file's own
// folder or below it, only from regular files within the input size limit: a `uri` of
// "../../etc/hostname", an absolute path, a symlink leading out, a FIFO (which blocked
// forever) or a directory (".", read as an endless file) is an error naming the uri.
struct BufferFolder {
  std::filesystem::path root;  // canonical folder of the glTF file
  std::string name;            // the glTF file, for messages
};

bool buffer_exists(const std::string& path, void*) {
  std::error_code ec;
  return std::filesystem::exists(std::filesystem::symlink_status(path, ec));  // errors are ReadWholeFile's
}

std::string keep_path(const std::string& path, void*) {
  return path;  // tinygltf's default expands ~ and $VARIABLES (wordexp): not for file contents
}

bool read_buffer(std::vector<unsigned char>* out, std::string* err, const std::string& path, void* user) {
  const auto& folder = *static_cast<const BufferFolder*>(user);
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path real = fs::weakly_canonical(path, ec);
  const std::string shown = excerpt(fs::path(path).lexically_relative(folder.root).string(), 200);
  const auto [end, rest] = std::mismatch(folder.root.begin(), folder.root.end(), real.begin(), real.end());
  if (ec || end != folder.root.end() || rest == real.end()) {
    *err = "buffer \"" + shown + "\" is outside the folder of the glTF file; external buffers are read only from it";
    return false;
  }
  try {
    const std::string bytes = read_file(real);
    out->assign(bytes.begin(), bytes.end());
    return true;
  } catch (const IoError& e) {
    *err = "buffer \"" + shown + "\": " + e.what();
    return false;
  }
}

bool refuse_write(std::string* err, const std::string&, const std::vector<unsigned char>&, void*) {
  *err = "writing is not supported";
  return false;
}

/// The JSON part of a glTF file: all of a .gltf, the first chunk of a .glb (clamped to the file).
std::string_view gltf_json_part(std::string_view bytes, bool binary) {
  if (!binary) return bytes;
  if (bytes.size() < 20) return {};
  std::uint32_t length = 0;
  std::memcpy(&length, bytes.data() + 12, 4);
  return bytes.substr(20, std::min<std::size_t>(length, bytes.size() - 20));
}

// The GLB container (header, JSON chunk, BIN chunk) checked before tinygltf reads it, each fault
// named by its byte where tinygltf says only "Invalid glTF binary.". Accepts what tinygltf 2.7
// accepts, except a BIN chunk whose length leaves no room for its 8-byte header: tinygltf takes
// it and copies the buffer from up to 8 bytes past the end of the file.
void check_glb_container(std::string_view bytes, const std::string& name) {
  const auto u32 = [&](std::uint64_t at) {
    std::uint32_t v = 0;
    std::memcpy(&v, bytes.data() + at, 4);
    return std::uint64_t{v};
  };
  const auto fail = [&](std::uint64_t byte, const std::string& what) {
    throw InvalidInputError(name + ": not a valid glTF binary (.glb) file: byte " + std::to_string(byte) + ": " + what);
  };
  const auto hex = [](std::uint64_t v) {
    char buf[16];
    std::snprintf(buf, sizeof buf, "0x%08llX", static_cast<unsigned long long>(v));
    return std::string(buf);
  };
  if (bytes.size() < 20) {
    throw InvalidInputError(name + ": not a valid glTF binary (.glb) file: " + std::to_string(bytes.size()) +
                            " bytes, shorter than its 12-byte header and 8-byte JSON chunk header");
  }
  if (bytes.substr(0, 4) != "glTF") fail(0, "no \"glTF\" magic");
  const std::uint64_t length = u32(8), json_length = u32(12);
  if (length > bytes.size()) {
    fail(8, "total length " + std::to_string(length) + " exceeds the file's " + std::to_string(bytes.size()) + " bytes");
  }
  if (u32(16) != 0x4E4F534A) fail(16, "the first chunk must be JSON (type 0x4E4F534A), not " + hex(u32(16)));
  if (json_length < 1 || 20 + json_length > length) {
    fail(12, "JSON chunk length " + std::to_string(json_length) + " does not fit the total length " +
                 std::to_string(length) + " (byte 8)");
  }
  const std::uint64_t bin_at = 20 + json_length;
  if (bin_at == length) return;  // no BIN chunk
  if (bin_at + 12 > length) {
    fail(bin_at, std::to_string(length - bin_at) + " bytes after the JSON chunk, too few for a BIN chunk");
  }
  const std::uint64_t bin_length = u32(bin_at);
  if (bin_length < 4 || bin_length % 4 != 0) {
    fail(bin_at, "BIN chunk length " + std::to_string(bin_length) + " must be a positive multiple of 4");
  }
  if (bin_at + 8 + bin_length > length) {
    fail(bin_at, "BIN chunk of " + std::to_string(bin_length) + " bytes (from byte " + std::to_string(bin_at + 8) +
                     ") runs past the total length " + std::to_string(length) + " (byte 8)");
  }
  if (u32(bin_at + 4) != 0x004E4942) fail(bin_at + 4, "the second chunk must be BIN (type 0x004E4942), not " + hex(u32(bin_at + 4)));
}

// ---------------------------------------------------------------- EXT_meshopt_compression

// A buffer view stored compressed: where its encoded bytes are and how to decode them.
struct MeshoptView {
  std::size_t view = 0;              // bufferView index
  std::size_t count = 0, stride = 0;  // decoded items and bytes per item
  std::string mode, filter;           // ATTRIBUTES, TRIANGLES or INDICES; NONE, OCTAHEDRAL, ...
};

// Rewrites a glTF file that uses EXT_meshopt_compression so that tinygltf can load it: every
// compressed view points at its encoded bytes, and the fallback buffers (which have no data)
// are dropped. Returns the rewritten file, or "" when it does not use the extension; `views`
// gets what decode_meshopt_views needs.
std::string unpack_meshopt_json(std::string_view bytes, bool binary, const std::string& name,
                                std::vector<MeshoptView>& views) {
  const std::string_view text = gltf_json_part(bytes, binary);
  if (text.find("EXT_meshopt_compression") == std::string_view::npos) return {};
  nlohmann::json doc = nlohmann::json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (!doc.is_object() || !doc.contains("bufferViews") || !doc["bufferViews"].is_array() || !doc.contains("buffers") ||
      !doc["buffers"].is_array()) {
    return {};  // tinygltf reports what is wrong
  }
  auto fail = [&](const std::string& what) -> void { throw InvalidInputError(name + ": EXT_meshopt_compression: " + what); };
  nlohmann::json& buffers = doc["buffers"];
  // Old buffer index -> new one, without the fallback buffers.
  std::vector<long> renumber(buffers.size(), -1);
  nlohmann::json kept = nlohmann::json::array();
  for (std::size_t i = 0; i < buffers.size(); ++i) {
    const nlohmann::json& b = buffers[i];
    const bool fallback = b.is_object() && b.contains("extensions") && b["extensions"].is_object() &&
                          b["extensions"].contains("EXT_meshopt_compression") &&
                          b["extensions"]["EXT_meshopt_compression"].value("fallback", false);
    if (!fallback) {
      renumber[i] = static_cast<long>(kept.size());
      kept.push_back(b);
    }
  }
  auto number = [&](const nlohmann::json& o, const char* key, bool required) -> std::size_t {
    if (!o.contains(key)) {
      if (required) fail(std::string("a buffer view's extension has no ") + key);
      return 0;
    }
    if (!o[key].is_number_unsigned()) fail(std::string(key) + " must be a non-negative integer");
    return o[key].get<std::size_t>();
  };
  nlohmann::json& bv = doc["bufferViews"];
  for (std::size_t v = 0; v < bv.size(); ++v) {
    nlohmann::json& view = bv[v];
    if (!view.is_object()) continue;
    const bool compressed = view.contains("extensions") && view["extensions"].is_object() &&
                            view["extensions"].contains("EXT_meshopt_compression");
    if (compressed) {
      const nlohmann::json e = view["extensions"]["EXT_meshopt_compression"];
      if (!e.is_object()) fail("the extension of buffer view " + std::to_string(v) + " is not an object");
      MeshoptView m;
      m.view = v;
      m.count = number(e, "count", true);
      m.stride = number(e, "byteStride", true);
      m.mode = e.value("mode", std::string());
      m.filter = e.value("filter", std::string("NONE"));
      const std::size_t buffer = number(e, "buffer", true);
      if (buffer >= renumber.size() || renumber[buffer] < 0) fail("buffer view " + std::to_string(v) + " reads a missing buffer");
      view["buffer"] = renumber[buffer];
      view["byteOffset"] = number(e, "byteOffset", false);
      view["byteLength"] = number(e, "byteLength", true);
      view.erase("byteStride");
      view.erase("extensions");
      views.push_back(std::move(m));
    } else if (view.contains("buffer") && view["buffer"].is_number_unsigned()) {
      const std::size_t buffer = view["buffer"].get<std::size_t>();
      if (buffer < renumber.size()) {
        if (renumber[buffer] < 0) fail("buffer view " + std::to_string(v) + " reads a fallback buffer without data");
        view["buffer"] = renumber[buffer];
      }
    }
  }
  doc["buffers"] = kept;
  for (const char* list : {"extensionsRequired", "extensionsUsed"}) {
    if (doc.contains(list) && doc[list].is_array()) {
      nlohmann::json rest = nlohmann::json::array();
      for (const auto& x : doc[list]) {
        if (x != "EXT_meshopt_compression") rest.push_back(x);
      }
      doc[list] = rest;
    }
  }
  std::string json = doc.dump();
  if (!binary) return json;
  json.resize((json.size() + 3) / 4 * 4, ' ');
  // The GLB container again: header, the new JSON chunk, the rest (the BIN chunk) as it was.
  std::uint32_t old_json = 0;
  std::memcpy(&old_json, bytes.data() + 12, 4);
  const std::size_t rest_at = std::min<std::size_t>(bytes.size(), 20 + std::size_t{old_json});
  const std::string_view rest = bytes.substr(rest_at);
  std::string out(bytes.substr(0, 12));
  const auto put = [&](std::uint32_t x) { out.append(reinterpret_cast<const char*>(&x), 4); };
  out.resize(8);
  put(static_cast<std::uint32_t>(12 + 8 + json.size() + rest.size()));
  put(static_cast<std::uint32_t>(json.size()));
  put(0x4E4F534Au);  // "JSON"
  out += json;
  out.append(rest.data(), rest.size());
  return out;
}

// Decodes the views unpack_meshopt_json found into new buffers appended to the model, and
// points the views at them. The decoded size is bounded (256 times the encoded bytes plus
// 1 MiB) so that a hostile file cannot ask for unbounded memory.
void decode_meshopt_views(tinygltf::Model& model, const std::vector<MeshoptView>& views, const std::string& name) {
  auto fail = [&](std::size_t v, const std::string& what) {
    throw InvalidInputError(name + ": EXT_meshopt_compression: buffer view " + std::to_string(v) + ": " + what);
  };
  for (const MeshoptView& m : views) {
    if (m.view >= model.bufferViews.size()) fail(m.view, "does not exist");
    tinygltf::BufferView& view = model.bufferViews[m.view];
    if (view.buffer < 0 || static_cast<std::size_t>(view.buffer) >= model.buffers.size()) fail(m.view, "no buffer");
    const std::vector<unsigned char>& src = model.buffers[static_cast<std::size_t>(view.buffer)].data;
    if (view.byteOffset > src.size() || view.byteLength > src.size() - view.byteOffset) {
      fail(m.view, "encoded bytes exceed the buffer");
    }
    const bool attributes = m.mode == "ATTRIBUTES";
    if (attributes ? (m.stride == 0 || m.stride % 4 != 0 || m.stride > 256) : (m.stride != 2 && m.stride != 4)) {
      fail(m.view, "byteStride " + std::to_string(m.stride) + " is not valid for mode " + m.mode);
    }
    const std::size_t limit = 256 * view.byteLength + (std::size_t{1} << 20);
    if (m.count > limit / m.stride) fail(m.view, "decodes to more than 256 times its encoded size");
    std::vector<unsigned char> out(m.count * m.stride);
    const unsigned char* in = src.data() + view.byteOffset;
    int rc = -1;
    if (attributes) {
      rc = meshopt_decodeVertexBuffer(out.data(), m.count, m.stride, in, view.byteLength);
    } else if (m.mode == "TRIANGLES") {
      if (m.count % 3 != 0) fail(m.view, "a TRIANGLES count must be a multiple of 3");
      rc = meshopt_decodeIndexBuffer(out.data(), m.count, m.stride, in, view.byteLength);
    } else if (m.mode == "INDICES") {
      rc = meshopt_decodeIndexSequence(out.data(), m.count, m.stride, in, view.byteLength);
    } else {
      fail(m.view, "unknown mode \"" + m.mode + "\"");
    }
    if (rc != 0) fail(m.view, "the encoded data is malformed");
    if (m.filter == "OCTAHEDRAL" && attributes && (m.stride == 4 || m.stride == 8)) {
      meshopt_decodeFilterOct(out.data(), m.count, m.stride);
    } else if (m.filter == "QUATERNION" && attributes && m.stride == 8) {
      meshopt_decodeFilterQuat(out.data(), m.count, m.stride);
    } else if (m.filter == "EXPONENTIAL" && attributes) {
      meshopt_decodeFilterExp(out.data(), m.count, m.stride);
    } else if (m.filter != "NONE") {
      fail(m.view, "filter " + m.filter + " is unknown or does not fit byteStride " + std::to_string(m.stride));
    }
    tinygltf::Buffer decoded;
    decoded.data = std::move(out);
    model.buffers.push_back(std::move(decoded));
    view.buffer = static_cast<int>(model.buffers.size() - 1);
    view.byteOffset = 0;
    view.byteLength = m.count * m.stride;
    view.byteStride = attributes ? m.stride : 0;
  }
}

glm::dmat4 node_matrix(const tinygltf::Node& node) {
  if (node.matrix.size() == 16) return glm::make_mat4(node.matrix.data());  // column-major, as glTF
  glm::dmat4 m(1.0);
  if (node.translation.size() == 3)
    m = glm::translate(m, glm::dvec3(node.translation[0], node.translation[1], node.translation[2]));
  if (node.rotation.size() == 4) {
    m *= glm::mat4_cast(
        glm::dquat(node.rotation[3], node.rotation[0], node.rotation[1], node.rotation[2]));  // w, x, y, z
  }
  if (node.scale.size() == 3) m = glm::scale(m, glm::dvec3(node.scale[0], node.scale[1], node.scale[2]));
  return m;
}

// The node of level of detail `level` (>= 1): the `level`-th id of the MSFT_lod extension on
// the scene's first root node that has it.
int lod_node(const tinygltf::Model& model, const std::vector<int>& roots, std::uint32_t level, const std::string& name) {
  for (const int n : roots) {
    if (n < 0 || static_cast<std::size_t>(n) >= model.nodes.size()) continue;
    const auto& ext = model.nodes[static_cast<std::size_t>(n)].extensions;
    const auto it = ext.find("MSFT_lod");
    if (it == ext.end() || !it->second.IsObject() || !it->second.Has("ids") || !it->second.Get("ids").IsArray()) continue;
    const tinygltf::Value& ids = it->second.Get("ids");
    if (level > ids.ArrayLen()) {
      throw InvalidInputError(name + ": level of detail " + std::to_string(level) + " does not exist (the file has " +
                              std::to_string(ids.ArrayLen() + 1) + " levels, 0 to " + std::to_string(ids.ArrayLen()) + ")");
    }
    const tinygltf::Value& id = ids.Get(static_cast<int>(level - 1));
    if (!id.IsInt()) throw InvalidInputError(name + ": MSFT_lod ids must be node indices");
    return id.Get<int>();
  }
  throw InvalidInputError(name + ": level of detail " + std::to_string(level) +
                          " asked for, but the scene has no levels of detail (no MSFT_lod extension)");
}

Mesh parse_gltf(std::string_view bytes, bool binary, const std::filesystem::path& source,
                const MeshReadParams& params) {
  const std::string name = source.string();
  if (bytes.size() > std::numeric_limits<unsigned int>::max())
    throw InvalidInputError(name + ": file too large for glTF");
  if (binary) check_glb_container(bytes, name);
  // tinygltf parses recursively (extras nested 20,000 deep overflowed the stack).
  check_json_nesting(gltf_json_part(bytes, binary), name);
  std::vector<MeshoptView> meshopt_views;
  const std::string unpacked = unpack_meshopt_json(bytes, binary, name, meshopt_views);
  if (!unpacked.empty()) bytes = unpacked;
  tinygltf::TinyGLTF loader;
  loader.SetImageLoader(&ignore_image, nullptr);
  std::error_code ec;
  BufferFolder folder{std::filesystem::weakly_canonical(std::filesystem::absolute(source).parent_path(), ec), name};
  loader.SetFsCallbacks({&buffer_exists, &keep_path, &read_buffer, &refuse_write, &folder});
  tinygltf::Model model;
  std::string err, warn;
  const std::string base_dir = source.has_parent_path() ? source.parent_path().string() : std::string(".");
  const bool ok =
      binary ? loader.LoadBinaryFromMemory(&model, &err, &warn, reinterpret_cast<const unsigned char*>(bytes.data()),
                                           static_cast<unsigned int>(bytes.size()), base_dir)
             : loader.LoadASCIIFromString(&model, &err, &warn, bytes.data(), static_cast<unsigned int>(bytes.size()),
                                          base_dir);
  if (!ok) {
    while (!err.empty() && (err.back() == '\n' || err.back() == ' ')) err.pop_back();
    throw InvalidInputError(name + ": not a valid glTF " + (binary ? "binary (.glb)" : "(.gltf)") +
                            " file: " + (err.empty() ? std::string("parse error") : err));
  }
  decode_meshopt_views(model, meshopt_views, name);

  // Which meshes to take, with which transforms: the default scene's nodes (depth-first with
  // an explicit stack; each node at most once, so a cyclic file cannot loop), or every mesh.
  std::vector<std::pair<int, glm::dmat4>> instances;
  if (!model.scenes.empty()) {
    const int scene = model.defaultScene >= 0 && static_cast<std::size_t>(model.defaultScene) < model.scenes.size()
                          ? model.defaultScene
                          : 0;
    std::vector<std::uint8_t> visited(model.nodes.size(), 0);
    std::vector<std::pair<int, glm::dmat4>> stack;
    std::vector<int> roots = model.scenes[static_cast<std::size_t>(scene)].nodes;
    if (params.lod > 0) roots = {lod_node(model, roots, params.lod, name)};
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.emplace_back(*it, glm::dmat4(1.0));
    while (!stack.empty()) {
      const auto [n, parent] = stack.back();
      stack.pop_back();
      if (n < 0 || static_cast<std::size_t>(n) >= model.nodes.size())
        throw InvalidInputError(name + ": node " + std::to_string(n) + " does not exist");
      if (visited[static_cast<std::size_t>(n)])
        throw InvalidInputError(name + ": node " + std::to_string(n) +
                                " is reached twice (the node tree has a cycle or a shared child)");
      visited[static_cast<std::size_t>(n)] = 1;
      const tinygltf::Node& node = model.nodes[static_cast<std::size_t>(n)];
      const glm::dmat4 m = params.file_coordinates ? glm::dmat4(1.0) : parent * node_matrix(node);
      if (node.mesh >= 0) instances.emplace_back(node.mesh, m);
      for (auto it = node.children.rbegin(); it != node.children.rend(); ++it) stack.emplace_back(*it, m);
    }
  } else {
    for (std::size_t i = 0; i < model.meshes.size(); ++i) instances.emplace_back(static_cast<int>(i), glm::dmat4(1.0));
  }

  // glTF is y-up, unless strandmesh wrote it otherwise (its placement record, which also
  // gives the units); the node transforms hold the pivot.
  UpAxis file_up = UpAxis::y;
  double scale = 1.0;
  if (model.asset.extras.IsObject() && model.asset.extras.Has("strandmesh")) {
    const tinygltf::Value& record = model.asset.extras.Get("strandmesh");
    if (record.IsObject() && record.Has("up_axis") && record.Get("up_axis").IsString() &&
        record.Get("up_axis").Get<std::string>() == "z") {
      file_up = UpAxis::z;
    }
    if (record.IsObject() && record.Has("scale") && record.Get("scale").IsNumber()) {
      const double s = record.Get("scale").GetNumberAsDouble();
      if (s > 0 && std::isfinite(s)) scale = s;
    }
  }
  if (params.file_coordinates) file_up = params.up_axis, scale = 1.0;
  auto axes = [&](const glm::dvec3& p) { return change_up_axis(p, file_up, params.up_axis); };
  const double inv_scale = 1.0 / scale;

  MeshAssembler out(name);
  const AccessorReader reader(model, name);
  constexpr int kFloat = TINYGLTF_COMPONENT_TYPE_FLOAT, kU8 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE,
                kU16 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, kU32 = TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT,
                kI8 = TINYGLTF_COMPONENT_TYPE_BYTE, kI16 = TINYGLTF_COMPONENT_TYPE_SHORT;
  for (const auto& [mesh_index, m] : instances) {
    if (mesh_index < 0 || static_cast<std::size_t>(mesh_index) >= model.meshes.size()) {
      throw InvalidInputError(name + ": mesh " + std::to_string(mesh_index) + " does not exist");
    }
    const glm::dmat3 normal_matrix = glm::transpose(glm::inverse(glm::dmat3(m)));
    const bool mirrored = glm::determinant(glm::dmat3(m)) < 0;  // a mirror flips the winding
    const auto& gmesh = model.meshes[static_cast<std::size_t>(mesh_index)];
    for (std::size_t pi = 0; pi < gmesh.primitives.size(); ++pi) {
      const tinygltf::Primitive& prim = gmesh.primitives[pi];
      const std::string what = "mesh " + std::to_string(mesh_index) + " primitive " + std::to_string(pi);
      if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) continue;  // points and lines carry no surface
      const auto attr = [&](const char* key) {
        const auto it = prim.attributes.find(key);
        return it == prim.attributes.end() ? -1 : it->second;
      };
      if (attr("POSITION") < 0) throw InvalidInputError(name + ": " + what + " has no POSITION attribute");
      const std::vector<double> pos =
          reader.read(attr("POSITION"), TINYGLTF_TYPE_VEC3, {kFloat, kI8, kU8, kI16, kU16}, what + " POSITION");
      const std::size_t nv = pos.size() / 3;
      std::vector<double> nrm, uv, branch;
      if (attr("NORMAL") >= 0) nrm = reader.read(attr("NORMAL"), TINYGLTF_TYPE_VEC3, {kFloat, kI8, kI16}, what + " NORMAL");
      if (attr("TEXCOORD_0") >= 0)
        uv = reader.read(attr("TEXCOORD_0"), TINYGLTF_TYPE_VEC2, {kFloat, kI8, kU8, kI16, kU16}, what + " TEXCOORD_0");
      if (attr("_BRANCH_ID") >= 0)
        branch = reader.read(attr("_BRANCH_ID"), TINYGLTF_TYPE_SCALAR, {kFloat, kU8, kU16}, what + " _BRANCH_ID");
      if ((!nrm.empty() && nrm.size() != 3 * nv) || (!uv.empty() && uv.size() != 2 * nv) ||
          (!branch.empty() && branch.size() != nv)) {
        throw InvalidInputError(name + ": " + what + ": attributes have different counts");
      }
      std::vector<double> idx;
      if (prim.indices >= 0) {
        idx = reader.read(prim.indices, TINYGLTF_TYPE_SCALAR, {kU8, kU16, kU32}, what + " indices");
      } else {
        idx.resize(nv);
        for (std::size_t i = 0; i < nv; ++i) idx[i] = static_cast<double>(i);
      }
      if (idx.size() % 3 != 0)
        throw InvalidInputError(name + ": " + what + ": index count " + std::to_string(idx.size()) +
                                " is not a multiple of 3");

      std::vector<std::uint32_t> welded(nv);
      std::vector<glm::dvec3> normal(nrm.empty() ? 0 : nv);
      for (std::size_t i = 0; i < nv; ++i) {
        const glm::dvec4 p = m * glm::dvec4(pos[3 * i], pos[3 * i + 1], pos[3 * i + 2], 1.0);
        welded[i] = out.add_vertex(axes(glm::dvec3(p) * inv_scale), what + " vertex " + std::to_string(i));
        if (!nrm.empty()) {
          normal[i] = axes(normal_matrix * glm::dvec3(nrm[3 * i], nrm[3 * i + 1], nrm[3 * i + 2]));
          out.offer_normal(welded[i], normal[i]);
        }
      }
      if (nrm.empty() && !idx.empty()) out.corner_without_normal();
      for (std::size_t t = 0; t < idx.size(); t += 3) {
        std::array<std::size_t, 3> c{};
        for (std::size_t k = 0; k < 3; ++k) {
          if (idx[t + k] >= static_cast<double>(nv)) {
            throw InvalidInputError(name + ": " + what + ": index " +
                                    std::to_string(static_cast<std::uint64_t>(idx[t + k])) + " is out of range (" +
                                    std::to_string(nv) + " vertices)");
          }
          c[k] = static_cast<std::size_t>(idx[t + k]);
        }
        if (mirrored) std::swap(c[1], c[2]);
        std::array<glm::vec2, 3> tuv{};
        if (!uv.empty()) {
          for (std::size_t k = 0; k < 3; ++k)
            tuv[k] = glm::vec2(static_cast<float>(uv[2 * c[k]]), static_cast<float>(uv[2 * c[k] + 1]));
        }
        const std::array<glm::dvec3, 3> tn =
            normal.empty() ? std::array<glm::dvec3, 3>{} : std::array<glm::dvec3, 3>{normal[c[0]], normal[c[1]], normal[c[2]]};
        std::optional<std::uint32_t> b;
        if (!branch.empty()) {
          const double id = branch[c[0]];
          if (!(id >= 0) || id > 4294967295.0 || id != std::floor(id)) {
            throw InvalidInputError(name + ": " + what + ": _BRANCH_ID " + std::to_string(id) +
                                    " is not a non-negative integer");
          }
          b = static_cast<std::uint32_t>(id);
        }
        out.add_triangle({welded[c[0]], welded[c[1]], welded[c[2]]}, uv.empty() ? nullptr : &tuv, b,
                         normal.empty() ? nullptr : &tn);
      }
    }
  }
  return out.finish();
}

// Undoes the placement strandmesh recorded in an OBJ or PLY header (meshio/placement.h); a
// file without the record keeps its coordinates.
Mesh unplace(Mesh mesh, std::string_view bytes, const MeshReadParams& params) {
  const std::optional<FilePlacement> fp = find_placement_comment(bytes);
  if (!fp || params.file_coordinates) return mesh;
  for (glm::dvec3& p : mesh.positions) p = change_up_axis((p + fp->translation) / fp->scale, fp->up, params.up_axis);
  for (glm::dvec3& n : mesh.normals) n = change_up_axis(n, fp->up, params.up_axis);
  for (auto& corners : mesh.corner_normals) {
    for (glm::vec3& n : corners) n = glm::vec3(change_up_axis(glm::dvec3(n), fp->up, params.up_axis));
  }
  return mesh;
}

}  // namespace

Mesh parse_mesh(std::string_view bytes, MeshFormat format, const std::filesystem::path& source,
                const MeshReadParams& params) {
  const std::string name = source.string();
  if (params.lod > 0 && format != MeshFormat::glb && format != MeshFormat::gltf) {
    throw InvalidInputError(name + ": levels of detail are read from glTF files (MSFT_lod); an OBJ or PLY file holds one");
  }
  switch (format) {
    case MeshFormat::glb:
      return parse_gltf(bytes, true, source, params);
    case MeshFormat::gltf:
      return parse_gltf(bytes, false, source, params);
    case MeshFormat::obj:
      return unplace(parse_obj(bytes, name), bytes, params);
    case MeshFormat::ply:
      return unplace(parse_ply(bytes, name), bytes, params);
  }
  throw InternalError("parse_mesh: unknown format");
}

Mesh read_mesh(const std::filesystem::path& path, const MeshReadParams& params) {
  const MeshFormat format = mesh_format_from_path(path);
  const std::string bytes = read_file(path);
  return parse_mesh(bytes, format, path, params);
}

}  // namespace sm
