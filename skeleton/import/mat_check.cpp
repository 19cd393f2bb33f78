// A walk over a MAT v5 file's structure before libmatio reads it (see mat_check.h).

#include "skeleton/import/mat_check.h"

#include <cstdint>
#include <cstring>

#include <zlib.h>

#include "core/errors.h"

namespace sm {
namespace {

// MAT-file data types and array classes (MATLAB's "MAT-File Format" document).
enum : std::uint32_t { miINT8 = 1, miUINT8 = 2, miINT16 = 3, miUINT16 = 4, miINT32 = 5, miUINT32 = 6, miSINGLE = 7,
                       miDOUBLE = 9, miINT64 = 12, miUINT64 = 13, miMATRIX = 14, miCOMPRESSED = 15, miUTF8 = 16,
                       miUTF16 = 17, miUTF32 = 18 };
enum : std::uint32_t { mxCELL = 1, mxSTRUCT = 2, mxOBJECT = 3, mxCHAR = 4, mxSPARSE = 5, mxDOUBLE = 6, mxUINT64 = 15 };

constexpr int kMaxDepth = 32;                                  // nested cells and structs
constexpr std::uint64_t kMaxInflated = std::uint64_t{1} << 30;  // bytes inflated in total
constexpr std::uint64_t kMaxMatrices = 10'000'000;             // arrays in the whole file

std::size_t type_size(std::uint32_t type) {
  switch (type) {
    case miINT8: case miUINT8: case miUTF8: return 1;
    case miINT16: case miUINT16: case miUTF16: return 2;
    case miINT32: case miUINT32: case miSINGLE: case miUTF32: return 4;
    case miDOUBLE: case miINT64: case miUINT64: return 8;
    default: return 0;
  }
}

class Walker {
 public:
  Walker(const std::string& name, bool swap) : name_(name), swap_(swap) {}

  [[noreturn]] void fail(std::uint64_t offset, const std::string& what) const {
    throw InvalidInputError(name_ + ": not a valid MAT file at byte " + std::to_string(offset) + ": " + what);
  }

  std::uint32_t u32(const unsigned char* p) const {
    std::uint32_t v;
    std::memcpy(&v, p, 4);
    return swap_ ? __builtin_bswap32(v) : v;
  }

  /// One data element of `bytes` at `pos`: its type, where its data starts and its size;
  /// `pos` moves past it (8-byte aligned, except after compressed elements).
  struct Element {
    std::uint32_t type = 0;
    std::size_t data = 0, size = 0;
  };
  Element element(const unsigned char* bytes, std::size_t n, std::size_t& pos, std::uint64_t base) const {
    if (n - pos < 8) fail(base + pos, "a data element tag runs past its end");
    Element e;
    const std::uint32_t first = u32(bytes + pos);
    if ((first >> 16) != 0) {  // small data element: type and size in one word, data in the next
      e.type = first & 0xffff;
      e.size = first >> 16;
      e.data = pos + 4;
      if (e.size > 4) fail(base + pos, "a small data element of more than 4 bytes");
      pos += 8;
      return e;
    }
    e.type = first;
    e.size = u32(bytes + pos + 4);
    e.data = pos + 8;
    if (e.size > n - e.data) fail(base + pos, "a data element of " + std::to_string(e.size) + " bytes runs past its end");
    pos = e.data + e.size;
    if (e.type != miCOMPRESSED) pos = std::min(n, (pos + 7) / 8 * 8);
    return e;
  }

  /// A miMATRIX element's contents (`bytes`, `n` long).
  void matrix(const unsigned char* bytes, std::size_t n, std::uint64_t base, int depth) {
    if (++matrices_ > kMaxMatrices) fail(base, "more than 10 million arrays");
    if (depth > kMaxDepth) fail(base, "cells or structs nested more than 32 deep");
    if (n == 0) return;  // an empty array (an unset struct field)
    std::size_t pos = 0;
    const Element flags = element(bytes, n, pos, base);
    if (flags.size < 8 || type_size(flags.type) != 4) fail(base, "array flags missing");
    const std::uint32_t cls = u32(bytes + flags.data) & 0xff;
    const std::uint32_t nzmax = u32(bytes + flags.data + 4);
    // Function handles and objects of MATLAB's own (opaque, in __function_workspace__) follow
    // another layout; libmatio skips them, and so does this walk (their size was checked).
    if (cls > mxUINT64 || cls == 0) return;
    const Element dims = element(bytes, n, pos, base);
    if (type_size(dims.type) != 4 || dims.size < 8 || dims.size % 4 != 0) fail(base + dims.data, "array dimensions missing");
    std::uint64_t count = 1;
    for (std::size_t k = 0; k < dims.size; k += 4) {
      const std::uint32_t d = u32(bytes + dims.data + k);
      if (d > 0x7fffffffu) fail(base + dims.data + k, "a negative or huge dimension");
      count = d == 0 ? 0 : count;
      if (count != 0 && d > (std::uint64_t{1} << 40) / count) fail(base + dims.data, "more than 2^40 elements");
      count *= d;
    }
    (void)element(bytes, n, pos, base);  // the array's name
    if (cls == mxCELL || cls == mxSTRUCT || cls == mxOBJECT) {
      std::uint64_t fields = 1;
      if (cls == mxOBJECT) (void)element(bytes, n, pos, base);  // class name
      if (cls != mxCELL) {
        const Element len = element(bytes, n, pos, base);
        if (type_size(len.type) != 4 || len.size < 4) fail(base + len.data, "field name length missing");
        const std::uint32_t width = u32(bytes + len.data);
        const Element names = element(bytes, n, pos, base);
        if (width == 0 || width > 4096) fail(base + len.data, "field names of " + std::to_string(width) + " characters");
        fields = names.size / width;
      }
      // Every element of every field is a data element of at least a tag's 8 bytes.
      if (fields != 0 && count > (n - pos) / 8 / fields) {
        fail(base, std::to_string(count) + " elements x " + std::to_string(fields) + " fields in " +
                       std::to_string(n - pos) + " bytes");
      }
      for (std::uint64_t k = 0; k < count * fields; ++k) {
        const Element child = element(bytes, n, pos, base);
        if (child.type != miMATRIX) fail(base + child.data, "a cell or field that is not an array");
        matrix(bytes + child.data, child.size, base + child.data, depth + 1);
      }
      return;
    }
    if (cls == mxSPARSE) {
      if (nzmax > n - pos) fail(base, "a sparse array of " + std::to_string(nzmax) + " values in " + std::to_string(n - pos) + " bytes");
      return;
    }
    if (cls == mxCHAR || (cls >= mxDOUBLE && cls <= mxUINT64)) {
      // Numbers may be stored in a smaller type than their class, never in fewer bytes than one
      // per element; libmatio allocates by the dimensions.
      const Element real = element(bytes, n, pos, base);
      if (count > real.size) {
        fail(base + real.data, std::to_string(count) + " elements in " + std::to_string(real.size) + " bytes of data");
      }
    }
  }

  /// The top-level elements of the file after its 128-byte header.
  void file(const unsigned char* bytes, std::size_t n) {
    std::size_t pos = 128;
    while (pos < n) {
      const std::size_t at = pos;
      const Element e = element(bytes, n, pos, 0);
      if (e.type == miMATRIX) {
        matrix(bytes + e.data, e.size, e.data, 0);
      } else if (e.type == miCOMPRESSED) {
        const std::string inflated = inflate(bytes + e.data, e.size, at);
        std::size_t p = 0;
        const auto* b = reinterpret_cast<const unsigned char*>(inflated.data());
        const Element inner = element(b, inflated.size(), p, at);
        if (inner.type == miMATRIX) matrix(b + inner.data, inner.size, at, 0);
      }
    }
  }

 private:
  std::string inflate(const unsigned char* data, std::size_t size, std::uint64_t at) {
    z_stream z{};
    if (inflateInit(&z) != Z_OK) fail(at, "zlib cannot start");
    z.next_in = const_cast<unsigned char*>(data);
    z.avail_in = static_cast<uInt>(std::min<std::size_t>(size, 0xffffffffu));
    std::string out;
    unsigned char buf[65536];
    int rc = Z_OK;
    while (rc == Z_OK) {
      z.next_out = buf;
      z.avail_out = sizeof buf;
      rc = ::inflate(&z, Z_NO_FLUSH);
      const std::size_t got = sizeof buf - z.avail_out;
      inflated_ += got;
      if (inflated_ > kMaxInflated) {
        inflateEnd(&z);
        fail(at, "more than 1 GiB of compressed data");
      }
      out.append(reinterpret_cast<const char*>(buf), got);
      if (rc == Z_BUF_ERROR && z.avail_in == 0) break;  // truncated: libmatio reads what is there
      if (rc == Z_BUF_ERROR) rc = Z_OK;
    }
    inflateEnd(&z);
    if (rc != Z_STREAM_END && rc != Z_BUF_ERROR) fail(at, "a compressed element zlib cannot inflate");
    return out;
  }

  const std::string& name_;
  bool swap_;
  std::uint64_t inflated_ = 0;
  std::uint64_t matrices_ = 0;
};

}  // namespace

void check_mat_structure(std::string_view bytes, const std::string& name) {
  if (bytes.size() < 128 || bytes.substr(0, 6) != "MATLAB") {
    throw InvalidInputError(name + ": not a MATLAB MAT file (expected a TreeQSM model saved by MATLAB or Octave, v5 or v7.3; "
                                   "MATLAB 4 files are not read)");
  }
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  const bool little = b[126] == 'I' && b[127] == 'M';
  const bool big = b[126] == 'M' && b[127] == 'I';
  if (!little && !big) throw InvalidInputError(name + ": not a valid MAT file: no endian indicator at byte 126");
  const unsigned version = little ? b[124] | (b[125] << 8) : (b[124] << 8) | b[125];
  if (version == 0x0200) return;  // v7.3: HDF5, read by libmatio through the HDF5 library
  if (version != 0x0100) throw InvalidInputError(name + ": not a valid MAT file: unknown version " + std::to_string(version));
  const bool host_little = [] {
    const std::uint16_t one = 1;
    unsigned char c;
    std::memcpy(&c, &one, 1);
    return c == 1;
  }();
  Walker(name, little != host_little).file(b, bytes.size());
}

}  // namespace sm
