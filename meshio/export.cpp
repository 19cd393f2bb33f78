// Mesh writers: glTF 2.0 (tinygltf), OBJ and PLY.
//
// The mesher's output is welded (one vertex per position) with UVs per corner, because the
// checks need the welded topology. File formats store one UV per vertex, so vertices are split
// here, and only where the corners around a vertex really disagree (a UV seam, or a branch
// boundary when `_BRANCH_ID` is written). Everything is done in a fixed order so that the same
// mesh gives the same bytes.
//
// Speed: a grown tree has millions of vertices, so the loops over vertices and corners run in
// parallel (oneTBB), each one writing only its own outputs or reducing fixed chunks combined in
// order: the bytes do not depend on the thread count. Files are streamed (write_mesh) or
// appended to one string reserved up front (encode_mesh), never copied whole. glTF's JSON
// comes from tinygltf, but its buffer is written here, chunk by chunk as it is formatted (and
// base64-encoded as it goes for .gltf): tinygltf's writer needs the whole buffer in memory and
// copies it (on a 3.4 M-triangle tree, 110 MB: export 0.8 -> 0.3 s for .glb, 2.65 -> 0.4 s for
// .gltf, the bytes unchanged).

#include "meshio/export.h"

#include <algorithm>
#include <array>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <ostream>
#include <span>
#include <sstream>
#include <streambuf>
#include <string_view>
#include <utility>

#include <meshoptimizer.h>
#include <nlohmann/json.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>
#include <tiny_gltf.h>

#include "core/errors.h"
#include "core/file_io.h"
#include "meshio/tree_attributes.h"

namespace sm {

namespace {

constexpr int kGlArrayBuffer = 34962;
constexpr int kGlElementArrayBuffer = 34963;
// Largest integer a float represents exactly: _BRANCH_ID is a float attribute (glTF forbids
// UNSIGNED_INT vertex attributes, and unsigned short would need padding to 4-byte strides).
constexpr std::uint32_t kMaxExactFloatInt = 1u << 24;
// Items per chunk of the parallel loops whose per-chunk results are combined in order.
constexpr std::size_t kChunk = 1 << 14;

// The key that decides whether two corners of one welded vertex may share an output vertex.
struct CornerKey {
  std::uint32_t u_bits = 0, v_bits = 0, branch = 0;
  std::array<std::uint32_t, 3> normal_bits{};
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
  check_size(mesh.corner_normals.size(), mesh.triangles.size(), "corner_normals");
  if (!mesh.corner_normals.empty() && mesh.normals.empty()) {
    throw InvalidInputError("mesh: corner_normals without (vertex) normals");
  }
  for (std::size_t f = 0; f < mesh.corner_normals.size(); ++f) {
    for (const glm::vec3& n : mesh.corner_normals[f]) {
      if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) {
        throw InvalidInputError("mesh: triangle " + std::to_string(f) + " has a non-finite corner normal");
      }
    }
  }
  // No file gets a non-finite number: a coordinate that is not finite, or that float32 (glTF)
  // cannot hold, is an error, as are non-finite normals and UVs.
  constexpr double kFloatSafe = 1e37;
  for (std::size_t v = 0; v < nv; ++v) {
    const glm::dvec3& p = mesh.positions[v];
    if (!(std::abs(p.x) <= kFloatSafe && std::abs(p.y) <= kFloatSafe && std::abs(p.z) <= kFloatSafe)) {
      throw InvalidInputError("mesh: vertex " + std::to_string(v) + " has a coordinate that is not finite or too large for float32");
    }
    if (!mesh.normals.empty()) {
      const glm::dvec3& n = mesh.normals[v];
      if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) {
        throw InvalidInputError("mesh: vertex " + std::to_string(v) + " has a non-finite normal");
      }
    }
  }
  for (std::size_t t = 0; t < mesh.corner_uvs.size(); ++t) {
    for (const auto& uv : mesh.corner_uvs[t]) {
      if (!std::isfinite(uv.x) || !std::isfinite(uv.y)) {
        throw InvalidInputError("mesh: triangle " + std::to_string(t) + " has a non-finite texture coordinate");
      }
    }
  }
  check_size(mesh.triangle_branch.size(), mesh.triangles.size(), "triangle_branch");
}

glm::vec3 unit_float(const glm::dvec3& n) {
  const double l = glm::length(n);
  const glm::dvec3 u = (l > 0 && std::isfinite(l)) ? n / l : glm::dvec3(0, 0, 1);
  return glm::vec3(u);
}

// Componentwise minimum and maximum of f(0) .. f(n - 1) (+-infinity when n = 0). Equal to the
// serial `lo = glm::min(lo, f(i)); hi = glm::max(hi, f(i))`, ties included (glm::min and max
// keep the earlier of two equal values, e.g. of -0 and +0, and ignore NaN): fixed chunks are
// reduced in parallel and combined in chunk order, whatever the thread count.
template <class F>
std::pair<glm::dvec3, glm::dvec3> bounds(std::size_t n, const F& f) {
  constexpr double inf = std::numeric_limits<double>::infinity();
  const std::pair<glm::dvec3, glm::dvec3> empty{glm::dvec3(inf), glm::dvec3(-inf)};
  std::vector<std::pair<glm::dvec3, glm::dvec3>> part((n + kChunk - 1) / kChunk, empty);
  tbb::parallel_for(std::size_t{0}, part.size(), [&](std::size_t k) {
    auto& [lo, hi] = part[k];
    for (std::size_t i = k * kChunk; i < std::min(n, (k + 1) * kChunk); ++i) {
      const glm::dvec3 x = f(i);
      lo = glm::min(lo, x);
      hi = glm::max(hi, x);
    }
  });
  std::pair<glm::dvec3, glm::dvec3> all = empty;
  for (const auto& [lo, hi] : part) {
    all.first = glm::min(all.first, lo);
    all.second = glm::max(all.second, hi);
  }
  return all;
}

// A file ready to be written. Preparing it did every check (an invalid mesh throws
// InvalidInputError there); writing only fails when the stream does.
struct PreparedFile {
  std::size_t size_hint = 0;                  // upper bound of the file size (the glTF JSON estimated)
  std::function<void(std::ostream&)> write;  // writes the whole file
};

// Writes the bytes of items [0, n) in order: format(begin, end) returns those of items
// [begin, end). Chunks of `chunk` items are formatted in parallel, a bounded number at a time,
// and written in order, so the output is the serial one for any thread count.
void write_chunks(std::ostream& out, std::size_t n, std::size_t chunk,
                  const std::function<std::string(std::size_t, std::size_t)>& format) {
  std::size_t next = 0;
  tbb::parallel_pipeline(
      16,
      tbb::make_filter<void, std::size_t>(tbb::filter_mode::serial_in_order,
                                          [&](tbb::flow_control& fc) -> std::size_t {
                                            if (next >= n) fc.stop();
                                            const std::size_t begin = next;
                                            next += chunk;
                                            return begin;
                                          }) &
          tbb::make_filter<std::size_t, std::string>(
              tbb::filter_mode::parallel,
              [&](std::size_t begin) { return format(begin, std::min(n, begin + chunk)); }) &
          tbb::make_filter<std::string, void>(tbb::filter_mode::serial_in_order, [&](const std::string& bytes) {
            out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
          }));
}

// ---------------------------------------------------------------- glTF

// Adds a tightly packed buffer view of `bytes` bytes at the end of the buffer layout `size`
// (every view starts 4-byte aligned); returns its offset.
std::size_t add_view(tinygltf::Model& model, std::size_t& size, std::size_t bytes, int target) {
  size = (size + 3) / 4 * 4;
  tinygltf::BufferView view;
  view.buffer = 0;
  view.byteOffset = size;
  view.byteLength = bytes;
  view.target = target;
  model.bufferViews.push_back(std::move(view));
  size += bytes;
  return model.bufferViews.back().byteOffset;
}

// Adds an accessor of `count` elements on the last buffer view; returns the accessor index.
int add_accessor(tinygltf::Model& model, std::size_t count, int component_type, int type) {
  tinygltf::Accessor acc;
  acc.bufferView = static_cast<int>(model.bufferViews.size() - 1);
  acc.byteOffset = 0;
  acc.componentType = component_type;
  acc.type = type;
  acc.count = count;
  model.accessors.push_back(std::move(acc));
  return static_cast<int>(model.accessors.size() - 1);
}

// One buffer view's contents: values of one type, item i computed by a function of i.
struct ViewData {
  std::size_t offset = 0;  // byte offset in the buffer
  std::size_t count = 0;   // items
  std::size_t bytes = 0;   // bytes per item
  std::function<void(std::size_t begin, std::size_t end, unsigned char* out)> put;  // items [begin, end)
};

template <class T, class F>
ViewData view_data(std::size_t offset, std::size_t count, F f) {
  ViewData v{offset, count, sizeof(T), {}};
  v.put = [f = std::move(f)](std::size_t begin, std::size_t end, unsigned char* out) {
    for (std::size_t i = begin; i < end; ++i) {
      const T value = f(i);
      std::memcpy(out + (i - begin) * sizeof(T), &value, sizeof(T));
    }
  };
  return v;
}

// Mantissa bits of quantized, compressed UVs (meshopt's exponential filter, one exponent per
// value): a relative precision of 2^-14, under 0.004 of a texture tile at v = 50.
constexpr int kUvMantissaBits = 14;

// Items per chunk when a view is written chunk by chunk (1-2 MB of output).
constexpr std::size_t kViewChunk = 1 << 17;

void put_u32(std::ostream& out, std::uint32_t x) {
  const char b[4] = {static_cast<char>(x & 0xFF), static_cast<char>((x >> 8) & 0xFF),
                     static_cast<char>((x >> 16) & 0xFF), static_cast<char>((x >> 24) & 0xFF)};
  out.write(b, 4);
}

// Writes the buffer the views make up (in offset order, zeros between them where a view is
// aligned), each view formatted chunk by chunk in parallel and written in order.
void write_views(std::ostream& out, const std::vector<ViewData>& views) {
  const char zeros[4] = {0, 0, 0, 0};
  std::size_t at = 0;
  for (const ViewData& v : views) {
    out.write(zeros, static_cast<std::streamsize>(v.offset - at));  // alignment (under 4 bytes)
    write_chunks(out, v.count, kViewChunk, [&](std::size_t begin, std::size_t end) {
      std::string bytes((end - begin) * v.bytes, '\0');
      v.put(begin, end, reinterpret_cast<unsigned char*>(bytes.data()));
      return bytes;
    });
    at = v.offset + v.count * v.bytes;
  }
}

// A stream buffer that writes the base64 encoding (RFC 4648, padded with '=') of the bytes
// put into it to another stream; finish() encodes the last, partial group.
class Base64Sink : public std::streambuf {
 public:
  explicit Base64Sink(std::ostream& out) : out_(out) {}
  void finish() {
    if (pending_ == 0) return;
    char text[4];
    encode_group(group_, pending_, text);
    out_.write(text, 4);
    pending_ = 0;
  }

 protected:
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    const char ch = traits_type::to_char_type(c);
    xsputn(&ch, 1);
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    const auto* bytes = reinterpret_cast<const unsigned char*>(s);
    std::size_t i = 0;
    const auto count = static_cast<std::size_t>(n);
    while (pending_ > 0 && pending_ < 3 && i < count) {  // complete the group begun by an earlier write
      group_[pending_++] = bytes[i++];
      if (pending_ == 3) {
        char text[4];
        encode_group(group_, 3, text);
        out_.write(text, 4);
        pending_ = 0;
      }
    }
    const std::size_t whole = (count - i) / 3;
    text_.resize(4 * whole);
    for (std::size_t g = 0; g < whole; ++g) encode_group(bytes + i + 3 * g, 3, text_.data() + 4 * g);
    out_.write(text_.data(), static_cast<std::streamsize>(text_.size()));
    for (i += 3 * whole; i < count && pending_ < 3;) group_[pending_++] = bytes[i++];  // under 3 left
    return n;
  }

 private:
  static void encode_group(const unsigned char* b, std::size_t n, char* text) {
    static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    const std::uint32_t x = (std::uint32_t(b[0]) << 16) | (n > 1 ? std::uint32_t(b[1]) << 8 : 0u) | (n > 2 ? b[2] : 0u);
    text[0] = kAlphabet[(x >> 18) & 63];
    text[1] = kAlphabet[(x >> 12) & 63];
    text[2] = n > 1 ? kAlphabet[(x >> 6) & 63] : '=';
    text[3] = n > 2 ? kAlphabet[x & 63] : '=';
  }

  std::ostream& out_;
  unsigned char group_[3] = {0, 0, 0};
  std::size_t pending_ = 0;
  std::string text_;
};

// The size of a GLB file with `json` bytes of JSON and a buffer of `size` bytes (chunks
// padded to 4 bytes). Throws InvalidInputError above 4 GiB, which the format cannot state.
std::size_t glb_size(std::size_t json, std::size_t size) {
  const std::size_t total = 12 + 8 + (json + 3) / 4 * 4 + (size > 0 ? 8 + (size + 3) / 4 * 4 : 0);
  if (total > std::numeric_limits<std::uint32_t>::max()) {
    throw InvalidInputError("mesh too large for a .glb file (" + std::to_string(total) +
                            " bytes; the format stores sizes in 32 bits): write .gltf, .obj or .ply");
  }
  return total;
}

// Writes a GLB file (the glTF 2.0 binary container: header, JSON chunk, BIN chunk) whose BIN
// chunk is `size` bytes made of `views`, formatted chunk by chunk as it is written: the
// buffer is never held whole (tinygltf's writer would copy it once more). `json` is the
// model's JSON, whose buffer 0 declares `size` bytes.
void write_glb(std::ostream& out, const std::string& json, std::size_t size, const std::vector<ViewData>& views) {
  const std::size_t json_padded = (json.size() + 3) / 4 * 4, bin_padded = (size + 3) / 4 * 4;
  const std::size_t total = glb_size(json.size(), size);
  out.write("glTF", 4);
  put_u32(out, 2);
  put_u32(out, static_cast<std::uint32_t>(total));
  put_u32(out, static_cast<std::uint32_t>(json_padded));
  put_u32(out, 0x4E4F534Au);  // "JSON"
  out.write(json.data(), static_cast<std::streamsize>(json.size()));
  out.write("   ", static_cast<std::streamsize>(json_padded - json.size()));  // spaces, as the format asks
  if (size == 0) return;
  put_u32(out, static_cast<std::uint32_t>(bin_padded));
  put_u32(out, 0x004E4942u);  // "BIN\0"
  write_views(out, views);
  const char zeros[4] = {0, 0, 0, 0};
  out.write(zeros, static_cast<std::streamsize>(bin_padded - size));
}

// tinygltf's JSON of `model` (its buffer empty: the writers here write its bytes), with
// buffer 0 declaring `size` bytes and no URI (a .glb's buffer is its BIN chunk).
nlohmann::json gltf_json(const tinygltf::Model& model, std::size_t size) {
  std::ostringstream text;
  tinygltf::TinyGLTF writer;
  if (!writer.WriteGltfSceneToStream(&model, text, /*prettyPrint=*/false, /*writeBinary=*/false)) {
    throw IoError("glTF serialization failed");
  }
  nlohmann::json json = nlohmann::json::parse(text.str());
  json["buffers"][0] = {{"byteLength", size}};
  return json;
}

// Writes a .gltf file: the model's JSON (gltf_json) with buffer 0 embedded
// as a base64 data URI of the bytes of `views`, encoded as it is written (tinygltf would hold
// the buffer, its encoding and the whole text in memory at once).
void write_gltf(std::ostream& out, nlohmann::json json, const std::vector<ViewData>& views) {
  constexpr std::string_view kMark = "@strandmesh-buffer@";
  json["buffers"][0]["uri"] = std::string(kMark);
  const std::string text = json.dump(2);
  const std::size_t mark = text.find(kMark);
  if (mark == std::string::npos) throw InternalError("write_gltf: buffer placeholder not found");
  out.write(text.data(), static_cast<std::streamsize>(mark));
  out << "data:application/octet-stream;base64,";
  Base64Sink encoder(out);
  std::ostream bytes(&encoder);
  bytes.exceptions(std::ios::badbit);
  write_views(bytes, views);
  encoder.finish();
  out.write(text.data() + mark + kMark.size(), static_cast<std::streamsize>(text.size() - mark - kMark.size()));
  out << '\n';
}

// One vertex attribute or the index list as it is stored: its accessor and the bytes of its
// buffer view (items of `stride` bytes, computed by `data.put`).
struct Stream {
  std::string attribute;  // "POSITION", ...; empty for the indices
  int component_type = TINYGLTF_COMPONENT_TYPE_FLOAT;
  int type = TINYGLTF_TYPE_SCALAR;
  bool normalized = false;
  std::size_t stride = 0;  // bytes per item in the buffer (a multiple of 4 for attributes)
  ViewData data;           // count, stride and the item writer (offset set when laid out)
  std::vector<double> min, max;  // accessor bounds (POSITION only)
  // EXT_meshopt_compression filter applied before the vertex codec when compressing:
  // OCTAHEDRAL takes `unit(i)` (8-bit octahedral normals), EXPONENTIAL the stream's own floats.
  enum class Filter { none, octahedral, exponential } filter = Filter::none;
  std::function<glm::vec3(std::size_t)> unit{};
};

template <class T, std::size_t N, class F>
ViewData packed_view(std::size_t count, F f) {
  ViewData v{0, count, sizeof(std::array<T, N>), {}};
  v.put = [f = std::move(f)](std::size_t begin, std::size_t end, unsigned char* out) {
    for (std::size_t i = begin; i < end; ++i) {
      const std::array<T, N> value = f(i);
      std::memcpy(out + (i - begin) * sizeof(value), value.data(), sizeof(value));
    }
  };
  return v;
}

// The streams of the export buffers `eb` in the file's frame: float or, with `quantize`,
// KHR_mesh_quantization's 16-bit positions (SHORT, padded to 8 bytes; the node holding the
// mesh scales them back by `dequant`) and 8-bit normals (BYTE normalized, padded to 4 bytes).
// Indices are 16-bit when every vertex number fits.
void add_tree_streams(std::vector<Stream>& streams, const std::shared_ptr<const ExportBuffers>& shared,
                      const std::shared_ptr<const TreeAttributes>& tree, const Placement& place, const ExportParams& p);
std::vector<glm::vec4> tangents(const ExportBuffers& eb, const Placement& place);

std::vector<Stream> gltf_streams(const std::shared_ptr<const ExportBuffers>& shared, const Placement& place,
                                 const ExportParams& params, const std::shared_ptr<const TreeAttributes>& tree,
                                 glm::dvec4& dequant) {
  const bool quantize = params.quantize;
  const ExportBuffers& eb = *shared;
  const std::size_t n = eb.positions.size();
  std::vector<Stream> streams;
  auto position = [&eb, place](std::size_t i) { return glm::vec3(place.position(eb.positions[i])); };
  // The validator compares min/max with the stored values exactly.
  const auto [lo, hi] = bounds(n, [&](std::size_t i) { return glm::dvec3(position(i)); });
  dequant = glm::dvec4(0, 0, 0, 1);  // translation, scale
  if (quantize && n > 0) {
    const glm::dvec3 centre = 0.5 * (glm::dvec3(lo) + glm::dvec3(hi));
    const double half = std::max({hi.x - centre.x, hi.y - centre.y, hi.z - centre.z, centre.x - lo.x,
                                  centre.y - lo.y, centre.z - lo.z});
    const double step = half > 0 ? half / 32767.0 : 1.0;
    dequant = glm::dvec4(centre, step);
    auto q = [&eb, place, centre, step](std::size_t i) {
      const glm::dvec3 p = glm::round((glm::dvec3(place.position(eb.positions[i])) - centre) / step);
      const glm::dvec3 c = glm::clamp(p, glm::dvec3(-32767.0), glm::dvec3(32767.0));
      return std::array<std::int16_t, 4>{static_cast<std::int16_t>(c.x), static_cast<std::int16_t>(c.y),
                                         static_cast<std::int16_t>(c.z), 0};
    };
    Stream s{"POSITION", TINYGLTF_COMPONENT_TYPE_SHORT, TINYGLTF_TYPE_VEC3, false, 8, packed_view<std::int16_t, 4>(n, q), {}, {}};
    glm::dvec3 qlo(32767.0), qhi(-32767.0);
    const auto [a, b] = bounds(n, [&](std::size_t i) {
      const auto v = q(i);
      return glm::dvec3(v[0], v[1], v[2]);
    });
    qlo = a, qhi = b;
    s.min = {qlo.x, qlo.y, qlo.z};
    s.max = {qhi.x, qhi.y, qhi.z};
    streams.push_back(std::move(s));
  } else {
    Stream s{"POSITION", TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, false, 12, view_data<glm::vec3>(0, n, position), {}, {}};
    s.min = {lo.x, lo.y, lo.z};
    s.max = {hi.x, hi.y, hi.z};
    streams.push_back(std::move(s));
  }
  if (!eb.normals.empty()) {
    auto normal = [&eb, place](std::size_t i) { return unit_float(place.direction(glm::dvec3(eb.normals[i]))); };
    if (quantize) {
      streams.push_back({"NORMAL", TINYGLTF_COMPONENT_TYPE_BYTE, TINYGLTF_TYPE_VEC3, true, 4,
                         packed_view<std::int8_t, 4>(n,
                                                     [normal](std::size_t i) {
                                                       const glm::vec3 v = glm::round(normal(i) * 127.0f);
                                                       return std::array<std::int8_t, 4>{static_cast<std::int8_t>(v.x),
                                                                                         static_cast<std::int8_t>(v.y),
                                                                                         static_cast<std::int8_t>(v.z), 0};
                                                     }),
                         {}, {}, Stream::Filter::octahedral, normal});
    } else {
      streams.push_back({"NORMAL", TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, false, 12,
                         view_data<glm::vec3>(0, n, normal), {}, {}});
    }
  }
  if (!eb.uvs.empty()) {
    streams.push_back({"TEXCOORD_0", TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, false, 8,
                       view_data<glm::vec2>(0, n, [&eb](std::size_t i) { return eb.uvs[i]; }), {}, {},
                       quantize ? Stream::Filter::exponential : Stream::Filter::none, {}});
  }
  if (params.tangents && !eb.uvs.empty()) {
    auto t = std::make_shared<const std::vector<glm::vec4>>(tangents(eb, place));
    streams.push_back({"TANGENT", TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, false, 16,
                       view_data<glm::vec4>(0, n, [t](std::size_t i) { return (*t)[i]; }), {}, {}});
  }
  if (tree) add_tree_streams(streams, shared, tree, place, params);
  if (!eb.branch.empty() && params.branch_ids) {
    streams.push_back({"_BRANCH_ID", TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR, false, 4,
                       view_data<float>(0, n, [&eb](std::size_t i) { return static_cast<float>(eb.branch[i]); }), {}, {}});
  }
  if (n <= 65536) {
    streams.push_back({"", TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT, TINYGLTF_TYPE_SCALAR, false, 2,
                       view_data<std::uint16_t>(0, eb.indices.size(),
                                                [&eb](std::size_t i) { return static_cast<std::uint16_t>(eb.indices[i]); }),
                       {}, {}});
  } else {
    streams.push_back({"", TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, false, 4,
                       view_data<std::uint32_t>(0, eb.indices.size(), [&eb](std::size_t i) { return eb.indices[i]; }),
                       {}, {}});
  }
  return streams;
}

// The branch of export vertex i: its triangle's (when split at branches) or its node's.
std::uint32_t branch_of(const ExportBuffers& eb, const TreeAttributes& t, std::size_t i) {
  return eb.branch.empty() ? t.vertex_branch[eb.source_vertex[i]] : eb.branch[i];
}

// Unit tangents along u (around the branch) in the file's frame, w the handedness of
// (normal, tangent, bitangent) as glTF's TANGENT wants it: per-triangle dP/du accumulated per
// vertex, made orthogonal to the normal (Lengyel's method, which MikkTSpace refines).
std::vector<glm::vec4> tangents(const ExportBuffers& eb, const Placement& place) {
  const std::size_t n = eb.positions.size();
  std::vector<glm::dvec3> tu(n, glm::dvec3(0)), tv(n, glm::dvec3(0));
  for (std::size_t t = 0; t + 2 < eb.indices.size(); t += 3) {
    const std::uint32_t a = eb.indices[t], b = eb.indices[t + 1], c = eb.indices[t + 2];
    const glm::dvec3 p0 = place.position(eb.positions[a]), e1 = place.position(eb.positions[b]) - p0,
                     e2 = place.position(eb.positions[c]) - p0;
    const glm::dvec2 w0(eb.uvs[a]), d1 = glm::dvec2(eb.uvs[b]) - w0, d2 = glm::dvec2(eb.uvs[c]) - w0;
    const double det = d1.x * d2.y - d2.x * d1.y;
    if (!(std::abs(det) > 1e-20)) continue;
    const glm::dvec3 su = (e1 * d2.y - e2 * d1.y) / det, sv = (e2 * d1.x - e1 * d2.x) / det;
    for (const std::uint32_t v : {a, b, c}) tu[v] += su, tv[v] += sv;
  }
  std::vector<glm::vec4> out(n);
  for (std::size_t i = 0; i < n; ++i) {
    const glm::dvec3 nrm = eb.normals.empty() ? glm::dvec3(0, 1, 0) : glm::dvec3(unit_float(place.direction(glm::dvec3(eb.normals[i]))));
    glm::dvec3 t = tu[i] - nrm * glm::dot(nrm, tu[i]);
    if (!(glm::length(t) > 1e-12)) {  // no UV gradient here: any direction across the normal
      t = std::abs(nrm.x) < 0.9 ? glm::cross(nrm, glm::dvec3(1, 0, 0)) : glm::cross(nrm, glm::dvec3(0, 1, 0));
    }
    t = glm::normalize(t);
    const double w = glm::dot(glm::cross(nrm, t), tv[i]) < 0 ? -1.0 : 1.0;
    out[i] = glm::vec4(glm::vec3(unit_float(t)), static_cast<float>(w));
  }
  return out;
}

// The streams of the tree attributes (tree_attributes.h) and the packed COLOR_0 / TEXCOORD_1.
void add_tree_streams(std::vector<Stream>& streams, const std::shared_ptr<const ExportBuffers>& shared,
                      const std::shared_ptr<const TreeAttributes>& tree, const Placement& place, const ExportParams& p) {
  const std::size_t n = shared->positions.size();
  const double scale = place.scale;
  auto scalar = [&](const char* name, std::function<float(std::size_t)> f) {
    streams.push_back({name, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_SCALAR, false, 4,
                       view_data<float>(0, n, [f = std::move(f)](std::size_t i) { return f(i); }), {}, {}});
  };
  auto vec3 = [&](const char* name, std::function<glm::vec3(std::size_t)> f) {
    streams.push_back({name, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, false, 12,
                       view_data<glm::vec3>(0, n, [f = std::move(f)](std::size_t i) { return f(i); }), {}, {}});
  };
  const auto& eb = shared;
  if (p.branch_level) scalar("_BRANCH_LEVEL", [eb, tree](std::size_t i) { return float(tree->level[branch_of(*eb, *tree, i)]); });
  if (p.root_distance) {
    scalar("_ROOT_DISTANCE", [eb, tree, scale](std::size_t i) { return float(double(tree->root_distance[eb->source_vertex[i]]) * scale); });
  }
  if (p.branch_pivot) {
    vec3("_BRANCH_PIVOT", [eb, tree, place](std::size_t i) { return glm::vec3(place.position(tree->pivot[branch_of(*eb, *tree, i)])); });
  }
  if (p.branch_direction) {
    vec3("_BRANCH_DIRECTION", [eb, tree, place](std::size_t i) { return unit_float(place.direction(tree->direction[branch_of(*eb, *tree, i)])); });
  }
  if (p.branch_phase) scalar("_BRANCH_PHASE", [eb, tree](std::size_t i) { return tree->phase[branch_of(*eb, *tree, i)]; });
  if (p.thickness) {
    scalar("_THICKNESS", [eb, tree, scale](std::size_t i) { return float(double(tree->thickness[eb->source_vertex[i]]) * scale); });
  }
  if (p.color) {  // unsigned bytes, normalized: each value over its maximum
    auto unorm = [](double x) { return static_cast<std::uint8_t>(std::lround(std::clamp(x, 0.0, 1.0) * 255.0)); };
    streams.push_back({"COLOR_0", TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_TYPE_VEC4, true, 4,
                       packed_view<std::uint8_t, 4>(n,
                                                    [eb, tree, unorm](std::size_t i) {
                                                      const TreeAttributes& t = *tree;
                                                      const std::uint32_t v = eb->source_vertex[i], b = branch_of(*eb, t, i);
                                                      auto over = [](double x, double m) { return m > 0 ? x / m : 0.0; };
                                                      return std::array<std::uint8_t, 4>{
                                                          unorm(over(t.root_distance[v], t.max_root_distance)),
                                                          unorm(over(t.thickness[v], t.max_thickness)), unorm(t.phase[b]),
                                                          unorm(over(t.level[b], t.max_level))};
                                                    }),
                       {}, {}});
  }
  if (p.uv1) {
    streams.push_back({"TEXCOORD_1", TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, false, 8,
                       view_data<glm::vec2>(0, n,
                                            [eb, tree, scale](std::size_t i) {
                                              const std::uint32_t v = eb->source_vertex[i];
                                              return glm::vec2(float(double(tree->root_distance[v]) * scale),
                                                               float(double(tree->thickness[v]) * scale));
                                            }),
                       {}, {}});
  }
}

// The bytes of a stream, whole.
std::string stream_bytes(const Stream& s) {
  std::string bytes(s.data.count * s.data.bytes, '\0');
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, s.data.count, kViewChunk),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      s.data.put(r.begin(), r.end(), reinterpret_cast<unsigned char*>(bytes.data()) + r.begin() * s.data.bytes);
                    });
  return bytes;
}

// EXT_meshopt_compression of one stream: attributes by the vertex codec, indices by the
// triangle codec (which reads them as unsigned int).
std::string meshopt_encode(const Stream& s, const std::vector<std::uint32_t>& indices, std::size_t vertices) {
  std::string out;
  if (s.attribute.empty()) {
    out.resize(meshopt_encodeIndexBufferBound(indices.size(), vertices));
    out.resize(meshopt_encodeIndexBuffer(reinterpret_cast<unsigned char*>(out.data()), out.size(), indices.data(),
                                         indices.size()));
  } else {
    std::string raw = stream_bytes(s);
    if (s.filter == Stream::Filter::octahedral) {  // 8-bit octahedral: 4 bytes per unit vector
      std::vector<float> xyzw(4 * s.data.count, 0.0f);
      for (std::size_t i = 0; i < s.data.count; ++i) {
        const glm::vec3 u = s.unit(i);
        std::memcpy(&xyzw[4 * i], &u, sizeof u);
      }
      meshopt_encodeFilterOct(raw.data(), s.data.count, 4, 8, xyzw.data());
    } else if (s.filter == Stream::Filter::exponential) {  // each float with its own exponent
      const std::vector<float> f = [&] {
        std::vector<float> v(raw.size() / 4);
        std::memcpy(v.data(), raw.data(), raw.size());
        return v;
      }();
      meshopt_encodeFilterExp(raw.data(), f.size(), 4, kUvMantissaBits, f.data());
    }
    out.resize(meshopt_encodeVertexBufferBound(s.data.count, s.stride));
    out.resize(meshopt_encodeVertexBuffer(reinterpret_cast<unsigned char*>(out.data()), out.size(), raw.data(),
                                          s.data.count, s.stride));
  }
  if (out.empty() && s.data.count > 0) throw InternalError("meshopt encoding failed");
  return out;
}

// The screen coverage below which each level gives way to the next (MSFT_screencoverage, one
// value per level, decreasing): a level's triangles are worth drawing while its density on
// the screen is at least that of the full mesh at half the screen, so level k is shown down to
// half of the next level's share of the full mesh's triangles; the last level is never culled.
std::vector<double> screen_coverage(const std::vector<std::size_t>& triangles) {
  std::vector<double> c;
  for (std::size_t k = 0; k + 1 < triangles.size(); ++k) {
    c.push_back(0.5 * double(triangles[k + 1]) / double(std::max<std::size_t>(triangles[0], 1)));
  }
  c.push_back(0.0);
  return c;
}

// One level's data in a glTF file: its export buffers, tree attributes and streams.
struct GltfLevel {
  std::shared_ptr<const ExportBuffers> buffers;
  std::vector<Stream> streams;
  glm::dvec4 dequant{0, 0, 0, 1};
  std::shared_ptr<const TreeAttributes> tree;
};

GltfLevel gltf_level(const Mesh& mesh, const Skeleton* skeleton, const ExportParams& params, const Placement& place) {
  GltfLevel l;
  ExportBuffers b = build_export_buffers(mesh, params);
  const auto too_big = std::find_if(b.branch.begin(), b.branch.end(), [](std::uint32_t id) { return id > kMaxExactFloatInt; });
  if (too_big != b.branch.end()) {
    throw InvalidInputError("mesh: branch id " + std::to_string(*too_big) +
                            " exceeds 2^24, the largest id _BRANCH_ID (a float attribute) stores exactly; "
                            "export without branch ids");
  }
  l.buffers = std::make_shared<const ExportBuffers>(std::move(b));
  const bool wants_tree = params.branch_level || params.root_distance || params.branch_pivot || params.branch_direction ||
                          params.branch_phase || params.thickness || params.color || params.uv1;
  if (wants_tree) {
    if (skeleton == nullptr) {
      throw InvalidInputError("the tree attributes (level, root_distance, pivot, direction, phase, thickness, color, "
                              "uv1) need the skeleton the mesh was made from");
    }
    l.tree = std::make_shared<const TreeAttributes>(compute_tree_attributes(mesh, *skeleton));
  }
  l.streams = gltf_streams(l.buffers, place, params, l.tree, l.dequant);
  return l;
}

// A glTF file of one mesh, or of levels of detail: one node (and mesh) per level, level 0 in
// the scene with MSFT_lod naming the others (lod.h), which are outside the scene so that a
// client without the extension shows level 0 alone.
PreparedFile prepare_gltf(std::span<const ExportLevel> levels, const ExportParams& params, const Placement& place,
                          bool binary) {
  const bool compress = params.compress == Compression::meshopt;
  std::vector<GltfLevel> data;
  for (const ExportLevel& level : levels) data.push_back(gltf_level(*level.mesh, level.skeleton, params, place));

  auto model = std::make_shared<tinygltf::Model>();
  model->asset.version = "2.0";
  model->asset.generator = "strandmesh";
  // The placement record the readers undo (meshio/placement.h).
  tinygltf::Value::Object record;
  record["up_axis"] = tinygltf::Value(std::string(place.to == UpAxis::y ? "y" : "z"));
  record["scale"] = tinygltf::Value(place.scale);
  model->asset.extras = tinygltf::Value(tinygltf::Value::Object{{"strandmesh", tinygltf::Value(std::move(record))}});
  model->buffers.emplace_back();

  tinygltf::Material material;
  material.name = "bark";
  material.pbrMetallicRoughness.baseColorFactor = {0.36, 0.25, 0.17, 1.0};
  material.pbrMetallicRoughness.metallicFactor = 0.0;
  material.pbrMetallicRoughness.roughnessFactor = 0.9;
  model->materials.push_back(std::move(material));

  // Lay out the views (uncompressed: the layout a meshopt decoder restores), one per stream,
  // level after level.
  std::size_t size = 0;
  std::vector<int> level_nodes;
  for (std::size_t k = 0; k < data.size(); ++k) {
    GltfLevel& level = data[k];
    tinygltf::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    for (Stream& st : level.streams) {
      const bool index = st.attribute.empty();
      st.data.offset = add_view(*model, size, st.data.count * st.data.bytes, index ? kGlElementArrayBuffer : kGlArrayBuffer);
      const std::size_t element = static_cast<std::size_t>(tinygltf::GetComponentSizeInBytes(static_cast<std::uint32_t>(st.component_type)) *
                                                           tinygltf::GetNumComponentsInType(static_cast<std::uint32_t>(st.type)));
      if (!index && (st.stride != element || compress)) model->bufferViews.back().byteStride = st.stride;
      const int acc = add_accessor(*model, st.data.count, st.component_type, st.type);
      model->accessors.back().normalized = st.normalized;
      model->accessors.back().minValues = st.min;
      model->accessors.back().maxValues = st.max;
      if (index) {
        prim.indices = acc;
      } else {
        prim.attributes[st.attribute] = acc;
      }
    }
    prim.material = 0;

    const std::string name = k == 0 ? std::string("tree") : "tree_lod" + std::to_string(k);
    tinygltf::Mesh gmesh;
    gmesh.name = name;
    if (level.tree) {  // the maxima the packed attributes (COLOR_0) were divided by
      tinygltf::Value::Object ranges;
      ranges["max_root_distance"] = tinygltf::Value(double(level.tree->max_root_distance) * place.scale);
      ranges["max_thickness"] = tinygltf::Value(double(level.tree->max_thickness) * place.scale);
      ranges["max_level"] = tinygltf::Value(int(level.tree->max_level));
      gmesh.extras = tinygltf::Value(tinygltf::Value::Object{{"strandmesh_attributes", tinygltf::Value(std::move(ranges))}});
    }
    gmesh.primitives.push_back(std::move(prim));
    const int mesh_index = static_cast<int>(model->meshes.size());
    model->meshes.push_back(std::move(gmesh));

    // The level's node sits at the pivot (its translation, kept in double precision: positions
    // are float32 offsets from it). Quantized positions are scaled back by a child node.
    const glm::dvec3 origin = place.translation();
    tinygltf::Node node;
    node.name = name;
    if (origin != glm::dvec3(0)) node.translation = {origin.x, origin.y, origin.z};
    level_nodes.push_back(static_cast<int>(model->nodes.size()));
    if (params.quantize) {
      node.children.push_back(static_cast<int>(model->nodes.size()) + 1);
      tinygltf::Node inner;
      inner.name = name + "_mesh";
      inner.mesh = mesh_index;
      inner.translation = {level.dequant.x, level.dequant.y, level.dequant.z};
      inner.scale = {level.dequant.w, level.dequant.w, level.dequant.w};
      model->nodes.push_back(std::move(node));
      model->nodes.push_back(std::move(inner));
    } else {
      node.mesh = mesh_index;
      model->nodes.push_back(std::move(node));
    }
  }
  if (params.quantize) {
    model->extensionsUsed.push_back("KHR_mesh_quantization");
    model->extensionsRequired.push_back("KHR_mesh_quantization");
  }
  if (data.size() > 1) {
    tinygltf::Value::Array ids, coverage;
    for (std::size_t k = 1; k < level_nodes.size(); ++k) ids.emplace_back(level_nodes[k]);
    std::vector<std::size_t> triangles;
    for (const ExportLevel& level : levels) triangles.push_back(level.mesh->triangle_count());
    for (const double c : screen_coverage(triangles)) coverage.emplace_back(c);
    tinygltf::Node& top = model->nodes[static_cast<std::size_t>(level_nodes[0])];
    top.extensions["MSFT_lod"] = tinygltf::Value(tinygltf::Value::Object{{"ids", tinygltf::Value(std::move(ids))}});
    top.extras = tinygltf::Value(tinygltf::Value::Object{{"MSFT_screencoverage", tinygltf::Value(std::move(coverage))}});
    model->extensionsUsed.push_back("MSFT_lod");  // used, not required: level 0 alone is the whole tree
  }

  tinygltf::Scene scene;
  scene.nodes.push_back(level_nodes[0]);
  model->scenes.push_back(std::move(scene));
  model->defaultScene = 0;

  std::vector<Stream> streams;
  std::vector<std::size_t> stream_level;
  std::vector<std::shared_ptr<const ExportBuffers>> shared;
  for (std::size_t k = 0; k < data.size(); ++k) {
    for (Stream& st : data[k].streams) {
      streams.push_back(std::move(st));
      stream_level.push_back(k);
    }
    shared.push_back(data[k].buffers);
  }
  std::vector<ViewData> views;
  for (const Stream& st : streams) views.push_back(st.data);
  if (!compress) {
    // The JSON is a few kilobytes; .gltf embeds the buffer as base64 (4 characters per 3 bytes).
    constexpr std::size_t kJsonBytes = 1 << 16;
    PreparedFile file;
    file.size_hint = (binary ? size : (size + 2) / 3 * 4) + kJsonBytes;
    nlohmann::json json = gltf_json(*model, size);
    if (binary) {
      std::string text = json.dump();  // compact, as tinygltf writes a .glb's
      (void)glb_size(text.size(), size);  // too large fails here, before a file is opened
      file.write = [shared, text = std::move(text), size, views = std::move(views)](std::ostream& out) {
        write_glb(out, text, size, views);
      };
    } else {
      file.write = [shared, json = std::move(json), views = std::move(views)](std::ostream& out) {
        write_gltf(out, json, views);
      };
    }
    return file;
  }

  // EXT_meshopt_compression: buffer 0 holds the encoded views (the GLB's BIN chunk); buffer 1
  // is the fallback of the decoded size, without data (so the extension is required).
  auto packed = std::make_shared<std::string>();
  std::vector<std::pair<std::size_t, std::size_t>> at;  // offset, length in buffer 0
  for (std::size_t k = 0; k < streams.size(); ++k) {
    const ExportBuffers& b = *shared[stream_level[k]];
    const std::string enc = meshopt_encode(streams[k], b.indices, b.positions.size());
    packed->resize((packed->size() + 3) / 4 * 4, '\0');
    at.emplace_back(packed->size(), enc.size());
    packed->append(enc);
  }
  nlohmann::json json = gltf_json(*model, packed->size());
  json["buffers"][1] = {{"byteLength", size}, {"extensions", {{"EXT_meshopt_compression", {{"fallback", true}}}}}};
  for (std::size_t k = 0; k < streams.size(); ++k) {
    nlohmann::json& view = json["bufferViews"][k];
    view["buffer"] = 1;
    view["extensions"]["EXT_meshopt_compression"] = {
        {"buffer", 0},
        {"byteOffset", at[k].first},
        {"byteLength", at[k].second},
        {"byteStride", streams[k].stride},
        {"count", streams[k].data.count},
        {"mode", streams[k].attribute.empty() ? "TRIANGLES" : "ATTRIBUTES"}};
    if (streams[k].filter == Stream::Filter::octahedral) view["extensions"]["EXT_meshopt_compression"]["filter"] = "OCTAHEDRAL";
    if (streams[k].filter == Stream::Filter::exponential) view["extensions"]["EXT_meshopt_compression"]["filter"] = "EXPONENTIAL";
  }
  json["extensionsUsed"].push_back("EXT_meshopt_compression");
  json["extensionsRequired"].push_back("EXT_meshopt_compression");
  const std::size_t bytes = packed->size();
  std::vector<ViewData> one{ViewData{0, bytes, 1, [packed](std::size_t begin, std::size_t end, unsigned char* out) {
                                        std::memcpy(out, packed->data() + begin, end - begin);
                                      }}};
  PreparedFile file;
  file.size_hint = (binary ? bytes : (bytes + 2) / 3 * 4) + (1 << 16);
  if (binary) {
    std::string text = json.dump();
    (void)glb_size(text.size(), bytes);
    file.write = [text = std::move(text), bytes, one](std::ostream& out) { write_glb(out, text, bytes, one); };
  } else {
    file.write = [json = std::move(json), one](std::ostream& out) { write_gltf(out, json, one); };
  }
  return file;
}

// ---------------------------------------------------------------- OBJ

// Longest `%.9g` of a double ("-1.23456789e-308", "-0.0000123456789") and longest 1-based
// index (2^32, ten digits).
constexpr std::size_t kMaxNumberChars = 16;
constexpr std::size_t kMaxIndexChars = 10;

// Writes a number as `%.9g` would print it, independent of the C locale; returns the end.
char* put_number(char* p, double x) {
  return std::to_chars(p, p + kMaxNumberChars, x, std::chars_format::general, 9).ptr;
}

char* put_text(char* p, std::string_view text) {
  std::memcpy(p, text.data(), text.size());
  return p + text.size();
}

const char* axis_name(UpAxis a) {
  return a == UpAxis::z ? "z" : "y";
}

std::string units_text(double scale) {
  if (scale == 1) return "units: metres";
  if (scale == 100) return "units: centimetres";
  if (scale == 1000) return "units: millimetres";
  char buf[64];
  std::snprintf(buf, sizeof buf, "units: %.9g per metre", scale);
  return buf;
}

std::string pivot_text(const Placement& p) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "input point (%.9g, %.9g, %.9g)", p.pivot.x, p.pivot.y, p.pivot.z);
  return buf;
}

// Moves the buffers into the file's frame (OBJ and PLY write them as they are).
void place_buffers(ExportBuffers& b, const Placement& place) {
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, b.positions.size(), 8192),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t i = r.begin(); i != r.end(); ++i) {
                        b.positions[i] = place.position(b.positions[i]);
                        if (!b.normals.empty()) b.normals[i] = glm::vec3(place.direction(glm::dvec3(b.normals[i])));
                      }
                    });
}

// The lines `prefix x y ...` of `dims`-dimensional items [begin, end) of `values`.
template <class Vec>
std::string obj_lines(std::string_view prefix, const std::vector<Vec>& values, std::size_t begin, std::size_t end) {
  constexpr auto dims = static_cast<std::size_t>(Vec::length());
  std::string text((end - begin) * (prefix.size() + dims * (kMaxNumberChars + 1) + 1), '\0');
  char* p = text.data();
  for (std::size_t i = begin; i < end; ++i) {
    p = put_text(p, prefix);
    for (std::size_t k = 0; k < dims; ++k) {
      *p++ = ' ';
      p = put_number(p, static_cast<double>(values[i][static_cast<glm::length_t>(k)]));
    }
    *p++ = '\n';
  }
  text.resize(static_cast<std::size_t>(p - text.data()));
  return text;
}

// The lines `f a/a/a b/b/b c/c/c` (or `f a b c`, `f a/a b/b c/c`, `f a//a ...`) of triangles
// [begin, end).
std::string obj_faces(const ExportBuffers& b, std::size_t begin, std::size_t end) {
  const bool uv = !b.uvs.empty(), nrm = !b.normals.empty();
  constexpr std::size_t kMaxLine = 2 + 3 * (3 * kMaxIndexChars + 3);
  std::string text((end - begin) * kMaxLine, '\0');
  char* p = text.data();
  for (std::size_t t = begin; t < end; ++t) {
    *p++ = 'f';
    for (std::size_t k = 0; k < 3; ++k) {
      char index[kMaxIndexChars];
      const std::size_t len = static_cast<std::size_t>(
          std::to_chars(index, index + sizeof index, std::uint64_t(b.indices[3 * t + k]) + 1).ptr - index);
      *p++ = ' ';
      p = put_text(p, {index, len});
      if (uv || nrm) {
        *p++ = '/';
        if (uv) p = put_text(p, {index, len});
        if (nrm) {
          *p++ = '/';
          p = put_text(p, {index, len});
        }
      }
    }
    *p++ = '\n';
  }
  text.resize(static_cast<std::size_t>(p - text.data()));
  return text;
}

PreparedFile prepare_obj(const Mesh& mesh, const ExportParams& params, const Placement& place) {
  auto b = std::make_shared<ExportBuffers>(build_export_buffers(mesh, params));
  place_buffers(*b, place);
  const std::string header = std::string("# strandmesh\n# up axis ") + axis_name(place.to) + ", " +
                             units_text(place.scale) + ", origin at " + pivot_text(place) + "\n# " +
                             placement_comment(place) + "\n";
  PreparedFile file;
  file.size_hint = header.size() + b->positions.size() * (2 + 3 * (kMaxNumberChars + 1)) +
                   b->uvs.size() * (3 + 2 * (kMaxNumberChars + 1)) +
                   b->normals.size() * (3 + 3 * (kMaxNumberChars + 1)) +
                   b->indices.size() / 3 * (2 + 3 * (3 * kMaxIndexChars + 3));
  file.write = [b, header](std::ostream& out) {
    out << header;
    write_chunks(out, b->positions.size(), kChunk,
                 [&](std::size_t i, std::size_t j) { return obj_lines("v", b->positions, i, j); });
    write_chunks(out, b->uvs.size(), kChunk, [&](std::size_t i, std::size_t j) { return obj_lines("vt", b->uvs, i, j); });
    write_chunks(out, b->normals.size(), kChunk,
                 [&](std::size_t i, std::size_t j) { return obj_lines("vn", b->normals, i, j); });
    write_chunks(out, b->indices.size() / 3, kChunk, [&](std::size_t i, std::size_t j) { return obj_faces(*b, i, j); });
  };
  return file;
}

// ---------------------------------------------------------------- PLY

// Writes `value` little endian at p; returns the end.
template <class T>
char* put_le(char* p, T value) {
  static_assert(std::is_trivially_copyable_v<T>);
  std::memcpy(p, &value, sizeof(T));
  if constexpr (std::endian::native == std::endian::big) std::reverse(p, p + sizeof(T));
  return p + sizeof(T);
}

PreparedFile prepare_ply(const Mesh& mesh, const ExportParams& params, const Placement& place) {
  auto b = std::make_shared<ExportBuffers>(build_export_buffers(mesh, params));
  place_buffers(*b, place);
  const bool uv = !b->uvs.empty(), nrm = !b->normals.empty();
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment strandmesh: up axis ";
  header += axis_name(place.to);
  header += std::string(", ") + units_text(place.scale) + ", origin at " + pivot_text(place) + "\ncomment " +
            placement_comment(place);
  header += "\nelement vertex " + std::to_string(b->positions.size()) + "\n";
  header += "property double x\nproperty double y\nproperty double z\n";
  if (nrm) header += "property float nx\nproperty float ny\nproperty float nz\n";
  if (uv) header += "property float s\nproperty float t\n";
  header += "element face " + std::to_string(b->indices.size() / 3) + "\n";
  header += "property list uchar uint vertex_indices\nend_header\n";
  const std::size_t vertex_bytes = 24 + (nrm ? 12 : 0) + (uv ? 8 : 0);
  constexpr std::size_t kFaceBytes = 13;

  PreparedFile file;
  file.size_hint = header.size() + b->positions.size() * vertex_bytes + b->indices.size() / 3 * kFaceBytes;
  file.write = [b, header, uv, nrm, vertex_bytes](std::ostream& out) {
    out << header;
    write_chunks(out, b->positions.size(), kChunk, [&](std::size_t begin, std::size_t end) {
      std::string bytes((end - begin) * vertex_bytes, '\0');
      char* p = bytes.data();
      for (std::size_t i = begin; i < end; ++i) {
        p = put_le(p, b->positions[i].x);
        p = put_le(p, b->positions[i].y);
        p = put_le(p, b->positions[i].z);
        if (nrm) {
          p = put_le(p, b->normals[i].x);
          p = put_le(p, b->normals[i].y);
          p = put_le(p, b->normals[i].z);
        }
        if (uv) {
          p = put_le(p, b->uvs[i].x);
          p = put_le(p, b->uvs[i].y);
        }
      }
      return bytes;
    });
    write_chunks(out, b->indices.size() / 3, kChunk, [&](std::size_t begin, std::size_t end) {
      std::string bytes((end - begin) * kFaceBytes, '\0');
      char* p = bytes.data();
      for (std::size_t t = begin; t < end; ++t) {
        p = put_le(p, std::uint8_t{3});
        for (std::size_t k = 0; k < 3; ++k) p = put_le(p, b->indices[3 * t + k]);
      }
      return bytes;
    });
  };
  return file;
}

PreparedFile prepare_file(std::span<const ExportLevel> levels, MeshFormat format, const ExportParams& params) {
  if (levels.empty()) throw InvalidInputError("export: no mesh to write");
  if (levels.size() > 1 && format != MeshFormat::glb && format != MeshFormat::gltf) {
    throw InvalidInputError("levels of detail in one file need glTF (.glb or .gltf); OBJ and PLY take one file per level");
  }
  const Mesh& mesh = *levels[0].mesh;
  ExportParams p = params;
  const Placement place = export_placement(mesh, format, params);
  switch (format) {
    case MeshFormat::glb:
      return prepare_gltf(levels, p, place, true);
    case MeshFormat::gltf:
      return prepare_gltf(levels, p, place, false);
    case MeshFormat::obj:
      p.branch_ids = false;  // not stored in OBJ: no reason to split at branch boundaries
      return prepare_obj(mesh, p, place);
    case MeshFormat::ply:
      p.branch_ids = false;
      return prepare_ply(mesh, p, place);
  }
  throw InternalError("encode_mesh: unknown format");
}

// A stream buffer appending to a string (no copy of the whole file, unlike std::ostringstream).
class StringSink : public std::streambuf {
 public:
  explicit StringSink(std::size_t reserve) { bytes_.reserve(reserve); }
  std::string take() { return std::move(bytes_); }

 protected:
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    bytes_.push_back(traits_type::to_char_type(c));
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    bytes_.append(s, static_cast<std::size_t>(n));
    return n;
  }

 private:
  std::string bytes_;
};

}  // namespace

ExportBuffers build_export_buffers(const Mesh& mesh, const ExportParams& params) {
  validate_mesh(mesh);
  const std::size_t nv = mesh.positions.size();
  const std::size_t nf = mesh.triangles.size();
  const bool with_uv = params.uvs && !mesh.corner_uvs.empty();
  // Per-branch attributes take the branch of each corner's triangle: split there too.
  const bool per_branch = params.branch_ids || params.branch_level || params.branch_pivot || params.branch_direction ||
                          params.branch_phase || params.color;
  const bool with_branch = per_branch && !mesh.triangle_branch.empty();
  const bool corner_normals = params.normals && !mesh.corner_normals.empty();

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
    if (corner_normals) {
      const glm::vec3& n = mesh.corner_normals[c / 3][c % 3];
      key.normal_bits = {std::bit_cast<std::uint32_t>(n.x), std::bit_cast<std::uint32_t>(n.y),
                         std::bit_cast<std::uint32_t>(n.z)};
    }
    return key;
  };

  // Distinct keys per vertex, in the order of their first corner; the copies of vertex v are
  // numbered consecutively after those of v-1, so unsplit meshes keep their vertex order.
  // corner_copy[c] is the copy corner c uses, among those of its vertex; base[v] the number of
  // the first copy of v (base[v + 1] holds the number of copies of v until the prefix sum).
  std::vector<std::uint32_t> corner_copy(3 * nf);
  std::vector<std::uint64_t> base(nv + 1, 0);
  const tbb::blocked_range<std::size_t> vertices(0, nv, 4096);
  tbb::parallel_for(vertices, [&](const tbb::blocked_range<std::size_t>& r) {
    std::vector<CornerKey> seen;
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      seen.clear();
      for (std::uint32_t i = start[v]; i < start[v + 1]; ++i) {
        const CornerKey key = key_of(corners[i]);
        std::size_t j = 0;
        while (j < seen.size() && !(seen[j] == key)) ++j;
        if (j == seen.size()) seen.push_back(key);
        corner_copy[corners[i]] = static_cast<std::uint32_t>(j);
      }
      base[v + 1] = seen.size();
    }
  });
  for (std::size_t v = 0; v < nv; ++v) base[v + 1] += base[v];
  const std::uint64_t out_count = base[nv];
  if (out_count > std::numeric_limits<std::uint32_t>::max()) {
    throw InvalidInputError("mesh: too many vertices after splitting seams for 32-bit indices");
  }

  ExportBuffers b;
  b.indices.resize(3 * nf);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, 3 * nf, 8192), [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t c = r.begin(); c != r.end(); ++c) {
      b.indices[c] = static_cast<std::uint32_t>(base[mesh.triangles[c / 3][c % 3]] + corner_copy[c]);
    }
  });

  // The place of every copy in the output: its number, or with `optimize` its position in
  // vertex-fetch order.
  std::vector<unsigned int> remap;
  if (params.optimize && nf > 0) {
    // Vertex cache order for the triangles, then vertices in first-use order (both
    // deterministic functions of the index buffer). The FIFO variant: our strips are local
    // already, and on them it matches the full optimizer (ACMR 0.695 vs 0.696 at cache size
    // 16 on a grown tree) at a fraction of its time (3.3 M triangles: about 0.4 vs 1.2 s).
    std::vector<unsigned int> reordered(b.indices.size());
    meshopt_optimizeVertexCacheFifo(reordered.data(), b.indices.data(), b.indices.size(), out_count, 16);
    remap.resize(out_count);
    meshopt_optimizeVertexFetchRemap(remap.data(), reordered.data(), reordered.size(), out_count);
    meshopt_remapIndexBuffer(b.indices.data(), reordered.data(), reordered.size(), remap.data());
  }

  const std::vector<glm::dvec3> computed =
      (params.normals && mesh.normals.empty()) ? angle_weighted_normals(mesh) : std::vector<glm::dvec3>{};
  const std::vector<glm::dvec3>& normals = mesh.normals.empty() ? computed : mesh.normals;

  // The attributes of each copy, taken from its first corner: all its corners have the same
  // key, hence bit-identical UVs, corner normals and branch ids. Every copy belongs to one welded vertex, so
  // the vertices are independent.
  b.positions.resize(out_count);
  b.source_vertex.resize(out_count);
  if (params.normals) b.normals.resize(out_count);
  if (with_uv) b.uvs.resize(out_count);
  if (with_branch) b.branch.resize(out_count);
  tbb::parallel_for(vertices, [&](const tbb::blocked_range<std::size_t>& r) {
    for (std::size_t v = r.begin(); v != r.end(); ++v) {
      std::uint32_t copies = 0;
      for (std::uint32_t i = start[v]; i < start[v + 1]; ++i) {
        const std::uint32_t c = corners[i];
        if (corner_copy[c] != copies) continue;  // not the first corner of its copy
        const std::uint64_t copy = base[v] + copies++;
        const std::size_t out = remap.empty() ? copy : remap[copy];
        b.positions[out] = mesh.positions[v];
        b.source_vertex[out] = static_cast<std::uint32_t>(v);
        if (corner_normals) {
          b.normals[out] = mesh.corner_normals[c / 3][c % 3];
        } else if (params.normals) {
          b.normals[out] = unit_float(normals[v]);
        }
        if (with_uv) b.uvs[out] = mesh.corner_uvs[c / 3][c % 3];
        if (with_branch) b.branch[out] = mesh.triangle_branch[c / 3];
      }
    }
  });
  return b;
}

Placement export_placement(const Mesh& mesh, MeshFormat format, const ExportParams& params) {
  if (!(params.scale > 0) || !std::isfinite(params.scale)) {
    throw InvalidInputError("export: scale must be a positive number, not " + std::to_string(params.scale));
  }
  Placement place;
  place.from = params.up_axis;
  place.to = params.file_up_axis.value_or(format == MeshFormat::ply ? params.up_axis : UpAxis::y);
  place.scale = params.scale;
  const Pivot pivot = params.pivot.value_or(format == MeshFormat::ply ? Pivot::origin : Pivot::root);
  if (pivot == Pivot::origin) return place;
  // The bounds of the vertices the triangles use (in mesh coordinates).
  validate_mesh(mesh);
  const std::size_t nf = mesh.triangles.size();
  if (nf == 0) return place;
  const auto [lo, hi] = bounds(3 * nf, [&](std::size_t c) { return mesh.positions[mesh.triangles[c / 3][c % 3]]; });
  const glm::dvec3 half = 0.5 * (hi - lo);
  glm::dvec3 at = 0.5 * (lo + hi);
  if (pivot == Pivot::root) {
    if (params.root) {
      at = *params.root;
    } else {  // the bottom centre of the bounds
      if (params.up_axis == UpAxis::z) at.z = lo.z; else at.y = lo.y;
    }
  }
  // On the export grid the float32 offsets of the meshing stage's positions are exact; a
  // pivot far outside the mesh (a root given wrongly) would make them inexact, nothing worse.
  place.pivot = snap_to_grid(at, export_grid_spacing(std::max({half.x, half.y, half.z})));
  return place;
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
  const ExportLevel level{&mesh, params.skeleton};
  return encode_mesh_levels({&level, 1}, format, params);
}

std::string encode_mesh_levels(std::span<const ExportLevel> levels, MeshFormat format, const ExportParams& params) {
  const PreparedFile file = prepare_file(levels, format, params);
  StringSink sink(file.size_hint);
  std::ostream out(&sink);
  out.exceptions(std::ios::badbit);  // a failed allocation propagates instead of only failing the stream
  file.write(out);
  return sink.take();
}

void write_mesh(const Mesh& mesh, const std::filesystem::path& path, const ExportParams& params) {
  write_mesh(mesh, path, params, {});
}

namespace {

// A stream buffer that passes bytes on to another stream and reports the share of `expected`
// bytes passed so far, about every 1 %.
class ProgressSink : public std::streambuf {
 public:
  ProgressSink(std::ostream& out, std::size_t expected, const ProgressFn& progress)
      : out_(out), expected_(std::max<std::size_t>(expected, 1)), progress_(progress) {}

 protected:
  int_type overflow(int_type c) override {
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    const char ch = traits_type::to_char_type(c);
    xsputn(&ch, 1);
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    out_.write(s, n);
    written_ += static_cast<std::size_t>(n);
    if (written_ >= next_) {
      progress_("export", std::min(1.0, double(written_) / double(expected_)));
      next_ = written_ + expected_ / 100;
    }
    return n;
  }

 private:
  std::ostream& out_;
  std::size_t expected_, written_ = 0, next_ = 0;
  const ProgressFn& progress_;
};

}  // namespace

void write_mesh(const Mesh& mesh, const std::filesystem::path& path, const ExportParams& params,
                const ProgressFn& progress) {
  const ExportLevel level{&mesh, params.skeleton};
  write_mesh_levels({&level, 1}, path, params, progress);
}

void write_mesh_levels(std::span<const ExportLevel> levels, const std::filesystem::path& path, const ExportParams& params,
                       const ProgressFn& progress) {
  if (progress) progress("export", 0);
  const MeshFormat format = mesh_format_from_path(path);
  PreparedFile file;
  try {
    file = prepare_file(levels, format, params);
  } catch (const InvalidInputError& e) {
    throw InvalidInputError(path.string() + ": " + e.what());
  }
  if (!progress) {
    write_file_atomically(path, file.write);
    return;
  }
  write_file_atomically(path, [&](std::ostream& out) {
    ProgressSink sink(out, file.size_hint, progress);
    std::ostream counted(&sink);
    counted.exceptions(std::ios::badbit);
    file.write(counted);
    counted.flush();
  });
  progress("export", 1);
}

}  // namespace sm
