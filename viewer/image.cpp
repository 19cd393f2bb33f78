// PNG encoding through stb_image_write, which Debian's libstb ships compiled (libstb.so),
// so no implementation macro is defined here.

#include "viewer/image.h"

#include <algorithm>
#include <unordered_set>

#include <stb/stb_image.h>
#include <stb/stb_image_write.h>

#include "core/errors.h"
#include "core/file_io.h"

namespace sm::viewer {

namespace {

void append_bytes(void* context, void* data, int size) {
  auto* out = static_cast<std::string*>(context);
  out->append(static_cast<const char*>(data), static_cast<std::size_t>(size));
}

}  // namespace

std::string encode_png(const Image& image) {
  const std::size_t expected =
      static_cast<std::size_t>(std::max(image.width, 0)) * static_cast<std::size_t>(std::max(image.height, 0)) * 4;
  if (image.width <= 0 || image.height <= 0 || image.rgba.size() != expected) {
    throw InvalidInputError("encode_png: the image is empty or its buffer does not hold width x height x 4 bytes");
  }
  // Highest zlib effort: the screenshots are committed, so small files matter more than the
  // few milliseconds.
  stbi_write_png_compression_level = 9;
  std::string out;
  if (!stbi_write_png_to_func(append_bytes, &out, image.width, image.height, 4, image.rgba.data(), image.width * 4)) {
    throw InvalidInputError("encode_png: stb_image_write failed");
  }
  return out;
}

void write_png(const std::filesystem::path& path, const Image& image) {
  write_file_atomically(path, encode_png(image));
}

Image read_png(const std::filesystem::path& path) {
  const std::string bytes = read_file(path);
  int w = 0, h = 0, n = 0;
  unsigned char* px = stbi_load_from_memory(reinterpret_cast<const unsigned char*>(bytes.data()),
                                            static_cast<int>(bytes.size()), &w, &h, &n, 4);
  if (!px) throw InvalidInputError(path.string() + ": not an image (" + stbi_failure_reason() + ")");
  Image img;
  img.width = w;
  img.height = h;
  img.rgba.assign(px, px + static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 4);
  stbi_image_free(px);
  return img;
}

std::size_t distinct_colors(const Image& image, std::size_t limit) {
  std::unordered_set<std::uint32_t> seen;
  for (std::size_t i = 0; i + 3 < image.rgba.size() && seen.size() < limit; i += 4) {
    seen.insert(std::uint32_t(image.rgba[i]) | std::uint32_t(image.rgba[i + 1]) << 8 |
                std::uint32_t(image.rgba[i + 2]) << 16);
  }
  return seen.size();
}

void flip_rows(Image& image) {
  const std::size_t row = static_cast<std::size_t>(image.width) * 4;
  for (int y = 0; y < image.height / 2; ++y) {
    auto a = image.rgba.begin() + static_cast<std::ptrdiff_t>(row * static_cast<std::size_t>(y));
    auto b = image.rgba.begin() + static_cast<std::ptrdiff_t>(row * static_cast<std::size_t>(image.height - 1 - y));
    std::swap_ranges(a, a + static_cast<std::ptrdiff_t>(row), b);
  }
}

}  // namespace sm::viewer
