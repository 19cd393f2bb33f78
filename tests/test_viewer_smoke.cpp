// Smoke test of the real drawing path: strandmesh-view renders a screenshot under xvfb-run
// with Mesa's software OpenGL, and the PNG must be a real picture (the right size, many
// colours). Skips with a message where Xvfb is missing or cannot start, or where the X
// server offers no OpenGL 3.3 (exit code 4 of strandmesh-view).

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "core/file_io.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"
#include "viewer/image.h"

namespace sm {
namespace {

// `p` in double quotes for sh (built with += : GCC 12 warns falsely on "literal" + string).
std::string shell_quoted(const std::filesystem::path& p) {
  std::string s = "\"";
  s += p.string();
  s += '"';
  return s;
}

bool on_path(const std::string& program) {
  std::string cmd = "command -v ";
  cmd += program;
  cmd += " >/dev/null 2>&1";
  return std::system(cmd.c_str()) == 0;
}

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Runs strandmesh-view with `args` under xvfb-run; returns the viewer's exit code, or -1
// when the viewer never ran (Xvfb did not start). The viewer's exit code goes through a file
// because xvfb-run's own exit code cannot tell its failures from the program's.
int run_under_xvfb(const std::filesystem::path& dir, const std::string& args) {
  const auto rc_file = dir / "rc.txt";
  const auto log_file = dir / "log.txt";
  std::filesystem::remove(rc_file);
  const std::string viewer = std::string(STRANDMESH_BINARY_DIR) + "/strandmesh-view";
  std::string cmd = "xvfb-run -a -s '-screen 0 1024x768x24' sh -c '";
  cmd += shell_quoted(viewer);
  cmd += " " + args + "; echo $? > ";
  cmd += shell_quoted(rc_file);
  cmd += "' > ";
  cmd += shell_quoted(log_file);
  cmd += " 2>&1";
  std::system(cmd.c_str());
  if (!std::filesystem::exists(rc_file)) return -1;
  return std::atoi(read_text(rc_file).c_str());
}

TEST(ViewerSmoke, ScreenshotUnderXvfb) {
  if (!on_path("xvfb-run")) GTEST_SKIP() << "xvfb-run is not installed (package xvfb); screenshot smoke test skipped";
  const auto dir = test::temp_dir("viewer_smoke");
  const auto skeleton = dir / "y_fork.json";
  write_file_atomically(skeleton, raw_skeleton_to_json(test::y_fork()));
  const auto png = dir / "shot.png";
  std::string args = shell_quoted(skeleton);
  args += " --screenshot ";
  args += shell_quoted(png);
  args += " --size 320x240 --layers mesh,wireframe,skeleton,legend --camera yaw=30,pitch=10";
  const int rc = run_under_xvfb(dir, args);
  const std::string log = read_text(dir / "log.txt");
  if (rc == -1) GTEST_SKIP() << "Xvfb could not start; screenshot smoke test skipped:\n" << log;
  if (rc == 4) GTEST_SKIP() << "no OpenGL 3.3 under Xvfb (is libgl1-mesa-dri installed?); skipped:\n" << log;
  ASSERT_EQ(rc, 0) << log;
  ASSERT_TRUE(std::filesystem::exists(png)) << log;
  EXPECT_GT(std::filesystem::file_size(png), 1000u);
  const viewer::Image img = viewer::read_png(png);
  EXPECT_EQ(img.width, 320);
  EXPECT_EQ(img.height, 240);
  // Not a single colour: background, shaded mesh, lines and legend text.
  EXPECT_GT(viewer::distinct_colors(img), 50u);
  // The tree is in the middle of the picture: the centre row is not all background.
  const std::size_t row = static_cast<std::size_t>(img.height / 2) * static_cast<std::size_t>(img.width) * 4;
  std::size_t differing = 0;
  for (int x = 0; x < img.width; ++x) {
    const std::size_t i = row + static_cast<std::size_t>(x) * 4;
    if (img.rgba[i] != img.rgba[row] || img.rgba[i + 1] != img.rgba[row + 1] || img.rgba[i + 2] != img.rgba[row + 2]) {
      ++differing;
    }
  }
  EXPECT_GT(differing, 3u);

  // A bad input fails cleanly with exit code 1 and no picture.
  const auto missing_png = dir / "none.png";
  std::string bad_args = shell_quoted(dir / "missing.json");
  bad_args += " --screenshot ";
  bad_args += shell_quoted(missing_png);
  const int bad = run_under_xvfb(dir, bad_args);
  EXPECT_EQ(bad, 1) << read_text(dir / "log.txt");
  EXPECT_FALSE(std::filesystem::exists(missing_png));
}

}  // namespace
}  // namespace sm
