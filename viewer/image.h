#pragma once
/// PNG output of rendered frames and small image statistics (for the screenshot tests).

#include <cstddef>
#include <filesystem>
#include <string>

#include "viewer/backend.h"

namespace sm::viewer {

/// Encodes an RGBA image as PNG bytes (stb_image_write). Throws InvalidInputError when the
/// image is empty or its buffer has the wrong size.
std::string encode_png(const Image& image);

/// Writes the image as a PNG file atomically (core/file_io.h). Throws IoError when the file
/// cannot be written.
void write_png(const std::filesystem::path& path, const Image& image);

/// Reads a PNG (or any format stb_image reads) as RGBA. Throws IoError or InvalidInputError.
Image read_png(const std::filesystem::path& path);

/// Number of distinct RGB colours in the image, counting up to `limit` (then stops).
std::size_t distinct_colors(const Image& image, std::size_t limit = 1 << 20);

/// Flips an image's rows in place (OpenGL reads bottom-up).
void flip_rows(Image& image);

}  // namespace sm::viewer
