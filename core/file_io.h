#pragma once
/// Reading whole files and writing files atomically.
///
/// Inputs: only regular files (or symlinks to them) are read, up to kMaxInputBytes; a FIFO, a
/// device (/dev/zero) or a directory is an IoError before anything is opened.
///
/// Outputs: every file is written to a temporary file `.NAME.tmpPID` in the target's directory
/// and renamed over the target only when writing succeeded, so a failure (an exception, a full
/// disk, a crash) never leaves a partial file under the requested name. A target that is a
/// symlink is followed (the file it points to is replaced, the link stays); a target that is a
/// directory, FIFO, device or socket is refused. The temporary files of a run are removed when
/// it is stopped by SIGINT, SIGTERM or SIGHUP, and the leftovers of runs that were killed
/// outright (SIGKILL, power loss: their process no longer exists) are removed by the next
/// write into the same directory. An OutputTransaction makes the outputs of one command
/// appear together, or none of them.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>
#include <string_view>
#include <vector>

namespace sm {

/// Largest input file read (bytes): 2 GiB, far above any tree or mesh the tool can process.
inline constexpr std::uintmax_t kMaxInputBytes = std::uintmax_t{2} << 30;

/// Reads the whole file. Throws IoError naming the path when it cannot be opened or read, is
/// not a regular file (directory, FIFO, device, socket), or is larger than `max_bytes`.
std::string read_file(const std::filesystem::path& path, std::uintmax_t max_bytes = kMaxInputBytes);

/// Checks, before any work, that `path` can be written as an output file: its directory
/// exists and is writable, and the target is absent, a regular file or a symlink to one.
/// Throws IoError naming the path and the rule ("is a directory", "is a FIFO or device, not
/// a regular file", "is a symlink to nothing", "directory ... does not exist", "... is not
/// writable").
void check_output_path(const std::filesystem::path& path);

/// Checks, before any work, that `dir` can receive output files: it is a writable directory,
/// or it is absent and its parent is a writable directory (it will be created). Throws IoError.
void check_output_dir(const std::filesystem::path& dir);

/// Writes `contents` to `path` atomically. Throws IoError on failure (nothing is left behind).
void write_file_atomically(const std::filesystem::path& path, std::string_view contents);

/// Calls `writer` with a binary stream on a temporary file, then renames it to `path`.
/// If `writer` throws or the stream fails, the temporary file is removed and the exception
/// (or an IoError) propagates; `path` is untouched.
void write_file_atomically(const std::filesystem::path& path, const std::function<void(std::ostream&)>& writer);

/// While one is alive, write_file_atomically keeps each finished temporary file instead of
/// renaming it; commit() renames them all, in the order they were written. Destroyed without
/// commit() (an exception in between), it removes them: no output of the command appears.
/// One at a time per process (a second throws InternalError); not for use across threads.
class OutputTransaction {
 public:
  OutputTransaction();
  ~OutputTransaction();
  OutputTransaction(const OutputTransaction&) = delete;
  OutputTransaction& operator=(const OutputTransaction&) = delete;
  /// Renames every pending file over its target. Throws IoError when one cannot be renamed
  /// (the ones renamed before it stay; the rest are removed).
  void commit();

  struct Pending;  ///< one finished temporary file and its target (defined in file_io.cpp)

 private:
  std::vector<Pending>* pending_;
};

/// Lower-case extension without the dot ("glb" for "tree.GLB"), empty when there is none.
std::string extension_of(const std::filesystem::path& path);

}  // namespace sm
