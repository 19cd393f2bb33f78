#pragma once
/// strandmesh as a library: a tree skeleton in, one watertight branch mesh out.
///
///   #include <strandmesh/strandmesh.h>
///
///   const strandmesh::Skeleton skeleton = strandmesh::read_skeleton("tree.json");
///   const strandmesh::Tree tree = strandmesh::mesh_skeleton(skeleton, {.seed = 2, .threads = 4});
///   strandmesh::write_mesh(tree, "tree.glb");
///
/// CMake: `find_package(strandmesh)` and link `strandmesh::strandmesh` (examples/mesh_tree).
/// mesh_skeleton runs the pipeline of `strandmesh mesh` (pipeline/pipeline.h): the same input
/// and options give the same mesh, and write_mesh the same bytes, as the command line.
///
/// Errors are exceptions derived from std::runtime_error (sm::Error, core/errors.h):
/// sm::InvalidInputError for a malformed skeleton, config or option (the message names the
/// place and the rule), sm::IoError for a file that cannot be read or written. write_mesh
/// leaves no partial file behind.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/mesh.h"
#include "meshio/export.h"
#include "skeleton/skeleton.h"

namespace strandmesh {

/// A skeleton as read or built in code: node ids, parent ids (-1 for the root), positions
/// and radii in metres; `add(id, parent_id, position, radius)` appends a node. Any number of
/// children per node; messy input is repaired with warnings (skeleton/skeleton.h).
using Skeleton = sm::RawSkeleton;
/// A welded triangle mesh: positions (metres, the skeleton's axes), triangles counter-clockwise
/// seen from outside, vertex normals and per-corner UVs (core/mesh.h).
using Mesh = sm::Mesh;

/// How mesh_skeleton runs. Every field has a default: `{}` meshes with the defaults of
/// configs/default.json.
struct Options {
  /// A config file (configs/*.json; every key: `strandmesh mesh --print-config`) replacing the
  /// defaults key by key; empty: the defaults.
  std::filesystem::path config;
  /// Random seed of the particle stage, replacing the config's (default 1).
  std::optional<std::uint64_t> seed;
  /// Particle spacing in metres, replacing the config's (0: derived from the skeleton).
  std::optional<double> spacing;
  /// Worker threads while it runs (0: every core; process-wide for that time). The mesh does
  /// not depend on it.
  int threads = 0;
  /// Called with (stage, fraction done in [0, 1]) while it runs, never concurrently.
  std::function<void(std::string_view stage, double fraction)> progress;
};

/// A meshed tree.
struct Tree {
  Mesh mesh;
  /// How write_mesh writes it (meshio/export.h: file up axis, pivot, scale, attributes): the
  /// config's "export" section, with the skeleton's up axis and root.
  sm::ExportParams output;
  /// What was repaired or left, one line per kind: "message (N×; e.g. node 12, ...)".
  std::vector<std::string> warnings;
};

/// Reads a skeleton file in any format `strandmesh mesh` reads (by extension, then content):
/// strandmesh JSON, SWC, TreeQSM .mat, QSM cylinder tables (.csv, .txt), OpenAlea .mtg.
Skeleton read_skeleton(const std::filesystem::path& path);

/// Meshes the tree: skeleton, particles, strands, contours, meshing and repairs.
Tree mesh_skeleton(const Skeleton& skeleton, const Options& options = {});

/// Writes the mesh in the format of the path's extension (.glb, .gltf, .obj, .ply), placed
/// as `tree.output` says (docs/export.md), atomically.
void write_mesh(const Tree& tree, const std::filesystem::path& path);

}  // namespace strandmesh
