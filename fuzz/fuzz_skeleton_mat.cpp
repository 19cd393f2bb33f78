// Fuzz target: TreeQSM MATLAB files, read through libmatio and sanitized
// (skeleton/import/formats.h). libmatio reads files only, so each input is written to a
// temporary file of this process first.
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include "fuzz/fuzz_reader.h"
#include "skeleton/build.h"
#include "skeleton/import/formats.h"

SM_FUZZ_READER(text) {
  static const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("strandmesh_fuzz_" + std::to_string(::getpid()) + ".mat");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
  (void)sm::build_skeleton(sm::read_treeqsm_mat(path));
}
