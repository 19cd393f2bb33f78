#pragma once
/// Reading whole files and writing files atomically.
///
/// Every output file is written to a temporary file in the same directory and renamed over
/// the target only when writing succeeded, so a failure (an exception, a full disk, a crash)
/// never leaves a partial file under the requested name.

#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>
#include <string_view>

namespace sm {

/// Reads the whole file. Throws IoError naming the path when it cannot be opened or read.
std::string read_file(const std::filesystem::path& path);

/// Writes `contents` to `path` atomically. Throws IoError on failure (nothing is left behind).
void write_file_atomically(const std::filesystem::path& path, std::string_view contents);

/// Calls `writer` with a binary stream on a temporary file, then renames it to `path`.
/// If `writer` throws or the stream fails, the temporary file is removed and the exception
/// (or an IoError) propagates; `path` is untouched.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& writer);

/// Lower-case extension without the dot ("glb" for "tree.GLB"), empty when there is none.
std::string extension_of(const std::filesystem::path& path);

}  // namespace sm
