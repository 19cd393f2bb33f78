#pragma once
/// Skeleton fixtures built in code, shared by every stage's tests (pmp-library's
/// tests/helpers.h is the model). All are z-up, in metres.

#include <filesystem>
#include <string>
#include <vector>

#include "skeleton/build.h"
#include "skeleton/skeleton.h"

namespace sm::test {

/// A straight vertical branch of `nodes` nodes, tapering from 0.1 to 0.05 m.
RawSkeleton straight_branch(int nodes = 6);
/// A trunk of three nodes that forks into two branches of three nodes each.
RawSkeleton y_fork(double angle_degrees = 35.0);
/// A trunk whose top node has three children.
RawSkeleton trifurcation();
/// A trunk whose top node has six children spread around it.
RawSkeleton six_children();
/// A branch with two zero-length edges (duplicate points), like Sapling output.
RawSkeleton zero_length_edges();
/// A fork whose lateral child is twice as thick as its parent.
RawSkeleton thick_child();
/// A trunk forking into a narrow (12 degree) main lateral that stays fused with the trunk for
/// a long way, and 3 cm above that fork a small lateral leaving at 75 degrees, which comes
/// apart from the fused section long before the fork's own split (a whorl in miniature).
RawSkeleton lateral_inside_fused_section();
/// A trunk of six whorls, each with 1 to 4 laterals at random azimuths and 30 to 90 degrees
/// from vertical, some of them forking once more (random, but fixed for a seed).
RawSkeleton random_whorl_tree(std::uint64_t seed);
/// A dense hub: a 1 m trunk (radius 0.1) with `twigs` twigs of radius 0.01 and length 1 m from
/// its top, spread by the golden angle around it and 0 to 69 degrees above the horizontal;
/// from a few hundred on they run through each other.
RawSkeleton star(int twigs);
/// Two laterals from forks 1 m apart on a trunk that cross each other 0.5 m out, away from
/// their forks (the loop trunk - lateral - crossing - lateral - trunk: one handle).
RawSkeleton crossing_laterals();
/// A single chain of `nodes` nodes (deep tree: no recursion over depth allowed anywhere).
RawSkeleton long_chain(int nodes = 100'000);
/// A random binary tree grown by the default random grower with this seed.
RawSkeleton grown_tree(std::uint64_t seed = 1);

/// Sanitized versions.
Skeleton built(const RawSkeleton& raw, const SkeletonParams& params = {});

/// The sample skeletons of tests/data/skeletons, sorted by name.
std::vector<std::filesystem::path> sample_skeletons();
/// A fresh empty temporary directory for one test.
std::filesystem::path temp_dir(const std::string& name);

/// The result of running the built strandmesh binary.
struct CmdResult {
  int code = -1;    ///< exit code (-1 when it did not exit normally)
  std::string out;  ///< stdout
  std::string err;  ///< stderr
};
/// Runs `build/strandmesh ARGS` through the shell, capturing both streams.
CmdResult run_cli(const std::string& args);
/// The same with environment assignments ("NAME=value ...", passed to env(1)).
CmdResult run_cli_env(const std::string& env, const std::string& args);

}  // namespace sm::test
