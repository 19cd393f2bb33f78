#include "tests/fixtures.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <sys/wait.h>
#include <unistd.h>

#include "core/file_io.h"
#include "core/rng.h"
#include "grow/random_grower.h"

namespace sm::test {

RawSkeleton straight_branch(int nodes) {
  RawSkeleton raw;
  raw.source = "straight_branch";
  for (int i = 0; i < nodes; ++i) {
    raw.add(i, i - 1, dvec3(0, 0, 0.4 * i), 0.1 - 0.05 * i / std::max(1, nodes - 1));
  }
  return raw;
}

RawSkeleton y_fork(double angle_degrees) {
  RawSkeleton raw;
  raw.source = "y_fork";
  raw.add(0, -1, dvec3(0, 0, 0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 0.5), 0.095);
  raw.add(2, 1, dvec3(0, 0, 1.0), 0.09);
  const double a = angle_degrees * std::numbers::pi / 180.0;
  const dvec3 d1(std::sin(a), 0, std::cos(a)), d2(-std::sin(a), 0, std::cos(a));
  raw.add(3, 2, dvec3(0, 0, 1.0) + 0.5 * d1, 0.07);
  raw.add(4, 3, dvec3(0, 0, 1.0) + 1.0 * d1, 0.06);
  raw.add(5, 2, dvec3(0, 0, 1.0) + 0.5 * d2, 0.055);
  raw.add(6, 5, dvec3(0, 0, 1.0) + 1.0 * d2, 0.045);
  return raw;
}

RawSkeleton lateral_inside_fused_section() {
  RawSkeleton raw;
  raw.source = "lateral_inside_fused_section";
  raw.add(0, -1, dvec3(0, 0, 0), 0.15);
  raw.add(1, 0, dvec3(0, 0, 0.5), 0.15);
  raw.add(2, 1, dvec3(0, 0, 1.0), 0.15);   // the fork
  raw.add(3, 2, dvec3(0, 0, 1.03), 0.14);  // the fork inside its fused section
  raw.add(4, 3, dvec3(0, 0, 1.8), 0.12);
  raw.add(5, 4, dvec3(0, 0, 2.6), 0.1);
  const double b = 12.0 * std::numbers::pi / 180.0, l = 75.0 * std::numbers::pi / 180.0;
  const dvec3 db(std::sin(b), 0, std::cos(b)), dl(0, std::sin(l), std::cos(l));
  raw.add(6, 2, dvec3(0, 0, 1.0) + 0.8 * db, 0.08);
  raw.add(7, 6, dvec3(0, 0, 1.0) + 1.6 * db, 0.07);
  raw.add(8, 3, dvec3(0, 0, 1.03) + 0.4 * dl, 0.04);
  raw.add(9, 8, dvec3(0, 0, 1.03) + 0.8 * dl, 0.035);
  return raw;
}

RawSkeleton random_whorl_tree(std::uint64_t seed) {
  Rng rng(seed);
  RawSkeleton raw;
  raw.source = "random_whorl_tree";
  std::int64_t id = 0;
  double r = 0.12;
  raw.add(id++, -1, dvec3(0), r);
  std::int64_t below = 0;
  dvec3 p(0);
  for (int whorl = 0; whorl < 6; ++whorl) {
    // Draws sequenced right to left (as GCC evaluated the former dvec3(...) arguments, whose
    // order C++ leaves unspecified): the same tree from every compiler.
    const double dz = rng.uniform(0.3, 0.5), dy = rng.uniform(-0.015, 0.015), dx = rng.uniform(-0.015, 0.015);
    p += dvec3(dx, dy, dz);
    r *= 0.85;
    const std::int64_t hub = id++;
    raw.add(hub, below, p, r);
    const auto laterals = static_cast<int>(1 + rng.below(4));
    for (int l = 0; l < laterals; ++l) {
      const double azimuth = 2 * std::numbers::pi * (l + rng.uniform(0, 0.3)) / laterals;
      const double tilt = rng.uniform(30, 90) * std::numbers::pi / 180.0;
      const dvec3 d(std::sin(tilt) * std::cos(azimuth), std::sin(tilt) * std::sin(azimuth), std::cos(tilt));
      double rl = r * rng.uniform(0.2, 0.7);
      std::int64_t parent = hub;
      dvec3 q = p;
      const auto segments = static_cast<int>(2 + rng.below(3));
      for (int k = 0; k < segments; ++k) {
        q += d * rng.uniform(0.15, 0.35);
        rl *= 0.85;
        raw.add(id, parent, q, rl);
        parent = id++;
        if (rng.chance(0.3)) {
          const double ey = rng.uniform(-0.5, 0.5), ex = rng.uniform(-0.5, 0.5);  // (sequenced, as above)
          const dvec3 e = glm::normalize(d + dvec3(ex, ey, 0.5));
          raw.add(id++, parent, q + 0.2 * e, 0.6 * rl);
        }
      }
    }
    below = hub;
  }
  return raw;
}

RawSkeleton trifurcation() {
  RawSkeleton raw;
  raw.source = "trifurcation";
  raw.add(10, -1, dvec3(0, 0, 0), 0.1);
  raw.add(11, 10, dvec3(0, 0, 0.6), 0.09);
  raw.add(12, 11, dvec3(0, 0, 1.2), 0.07);
  raw.add(13, 11, dvec3(0.4, 0, 1.0), 0.05);
  raw.add(14, 11, dvec3(-0.3, 0.3, 1.0), 0.04);
  return raw;
}

RawSkeleton six_children() {
  RawSkeleton raw;
  raw.source = "six_children";
  raw.add(0, -1, dvec3(0, 0, 0), 0.12);
  raw.add(1, 0, dvec3(0, 0, 0.6), 0.11);
  for (int k = 0; k < 6; ++k) {
    const double phi = 2 * std::numbers::pi * k / 6.0;
    const dvec3 d = k == 0 ? dvec3(0, 0, 1) : glm::normalize(dvec3(std::cos(phi), std::sin(phi), 1.2));
    raw.add(2 + k, 1, dvec3(0, 0, 0.6) + 0.5 * d, k == 0 ? 0.08 : 0.03 + 0.004 * k);
  }
  return raw;
}

RawSkeleton zero_length_edges() {
  RawSkeleton raw;
  raw.source = "zero_length_edges";
  raw.add(0, -1, dvec3(0, 0, 0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 0.5), 0.09);
  raw.add(2, 1, dvec3(0, 0, 0.5), 0.09);  // duplicate of 1
  raw.add(3, 2, dvec3(0, 0, 1.0), 0.08);
  raw.add(4, 3, dvec3(0, 0, 1.0), 0.0);  // zero-length tip with zero radius
  raw.add(5, 2, dvec3(0.3, 0, 0.8), 0.04);
  return raw;
}

RawSkeleton thick_child() {
  RawSkeleton raw;
  raw.source = "thick_child";
  raw.add(0, -1, dvec3(0, 0, 0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 0.5), 0.05);
  raw.add(2, 1, dvec3(0, 0, 1.0), 0.04);
  raw.add(3, 1, dvec3(0.4, 0, 0.8), 0.1);  // twice as thick as its parent
  return raw;
}

RawSkeleton star(int twigs) {
  RawSkeleton raw;
  raw.source = "star";
  raw.add(0, -1, dvec3(0), 0.1);
  raw.add(1, 0, dvec3(0, 0, 1), 0.1);
  for (int i = 0; i < twigs; ++i) {
    const double a = 2.399963 * i, e = 1.2 * std::fmod(0.618034 * i, 1.0);  // golden-angle spread
    raw.add(2 + i, 1, dvec3(std::cos(a) * std::cos(e), std::sin(a) * std::cos(e), 1 + std::sin(e)), 0.01);
  }
  return raw;
}

RawSkeleton crossing_laterals() {
  RawSkeleton raw;
  raw.source = "crossing_laterals";
  raw.add(0, -1, dvec3(0, 0, 0), 0.08);
  raw.add(1, 0, dvec3(0, 0, 1.0), 0.07);
  raw.add(2, 1, dvec3(0, 0, 2.0), 0.06);
  raw.add(3, 2, dvec3(0, 0, 3.0), 0.05);
  raw.add(4, 1, dvec3(0.5, 0, 1.5), 0.035);     // rising lateral from z = 1
  raw.add(5, 4, dvec3(1.0, 0.0, 2.0), 0.03);
  raw.add(6, 2, dvec3(0.5, 0.05, 1.5), 0.035);  // falling lateral from z = 2, crossing it near x = 0.5
  raw.add(7, 6, dvec3(1.0, 0.1, 1.0), 0.03);
  return raw;
}

RawSkeleton long_chain(int nodes) {
  RawSkeleton raw;
  raw.source = "long_chain";
  raw.id.reserve(std::size_t(nodes));
  for (int i = 0; i < nodes; ++i) {
    // A gentle helix so frames have something to transport.
    const double t = 0.01 * i;
    raw.add(i, i - 1, dvec3(0.2 * std::cos(t), 0.2 * std::sin(t), 0.05 * i), 0.02);
  }
  return raw;
}

RawSkeleton grown_tree(std::uint64_t seed) {
  RandomGrowParams p;
  p.seed = seed;
  return grow_random(p);
}

Skeleton built(const RawSkeleton& raw, const SkeletonParams& params) {
  return build_skeleton(raw, params).skeleton;
}

std::vector<std::filesystem::path> sample_skeletons() {
  std::vector<std::filesystem::path> files;
  const std::filesystem::path dir = STRANDMESH_SAMPLE_DIR;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return files;
  for (const auto& e : std::filesystem::directory_iterator(dir)) {
    const auto ext = e.path().extension().string();
    if (ext == ".json" || ext == ".swc") files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

std::filesystem::path temp_dir(const std::string& name) {
  const auto dir =
      std::filesystem::temp_directory_path() / ("strandmesh_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

CmdResult run_cli(const std::string& args) {
  return run_cli_env("", args);
}

CmdResult run_cli_env(const std::string& env, const std::string& args) {
  const std::filesystem::path dir = temp_dir("cli_run");
  const std::string cmd = (env.empty() ? std::string() : "env " + env + " ") + std::string(STRANDMESH_BINARY_DIR) +
                          "/strandmesh " + args + " >" + (dir / "out").string() + " 2>" + (dir / "err").string();
  const int status = std::system(cmd.c_str());
  CmdResult r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.out = read_file(dir / "out");
  r.err = read_file(dir / "err");
  return r;
}

}  // namespace sm::test
