// The public library (include/strandmesh/strandmesh.h): the same mesh as the pipeline, options
// applied, errors as documented. (Built against the installed package: test install_example.)

#include <gtest/gtest.h>

#include <strandmesh/strandmesh.h>

#include "core/errors.h"
#include "core/file_io.h"
#include "pipeline/pipeline.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"

namespace sm {
namespace {

TEST(Api, MeshesLikeThePipeline) {
  const strandmesh::Skeleton skeleton = test::y_fork(40.0);
  const strandmesh::Tree tree = strandmesh::mesh_skeleton(skeleton, {.seed = 3});
  PipelineParams p;
  p.particles.seed = 3;
  const PipelineResult r = run_pipeline(skeleton, p);
  EXPECT_EQ(tree.mesh.positions, r.mesh.mesh.positions);
  EXPECT_EQ(tree.mesh.triangles, r.mesh.mesh.triangles);
  EXPECT_EQ(tree.output.up_axis, UpAxis::z);
  EXPECT_EQ(tree.output.root, r.skeleton.skeleton.position[0]);
  // Another seed, another mesh; the thread count changes nothing.
  const strandmesh::Tree seed1 = strandmesh::mesh_skeleton(skeleton, {.seed = 1});
  EXPECT_NE(seed1.mesh.positions, tree.mesh.positions);
  EXPECT_EQ(strandmesh::mesh_skeleton(skeleton, {.seed = 3, .threads = 1}).mesh.positions, tree.mesh.positions);
}

TEST(Api, ConfigFileAndProgress) {
  const auto dir = test::temp_dir("api_config");
  write_file_atomically(dir / "config.json", R"({"meshing": {"tip_dome": 0}, "export": {"scale": 100}})");
  const strandmesh::Skeleton skeleton = test::straight_branch();
  std::size_t calls = 0;
  const strandmesh::Tree flat = strandmesh::mesh_skeleton(
      skeleton, {.config = dir / "config.json", .progress = [&](std::string_view, double f) {
                   EXPECT_GE(f, 0.0);
                   EXPECT_LE(f, 1.0);
                   ++calls;
                 }});
  EXPECT_GT(calls, 0u);
  EXPECT_EQ(flat.output.scale, 100.0);  // the config's export section goes to write_mesh
  // A flat tip: nothing above the tip node's section (2 m), where the default dome rises.
  double top_flat = 0, top_dome = 0;
  for (const auto& v : flat.mesh.positions) top_flat = std::max(top_flat, v.z);
  for (const auto& v : strandmesh::mesh_skeleton(skeleton).mesh.positions) top_dome = std::max(top_dome, v.z);
  EXPECT_NEAR(top_flat, 2.0, 1e-6);
  EXPECT_GT(top_dome, 2.01);
  std::filesystem::remove_all(dir);
}

TEST(Api, ReadsMeshesAndWrites) {
  const auto dir = test::temp_dir("api_files");
  write_file_atomically(dir / "tree.json", raw_skeleton_to_json(test::trifurcation()));
  const strandmesh::Tree tree = strandmesh::mesh_skeleton(strandmesh::read_skeleton(dir / "tree.json"));
  EXPECT_FALSE(tree.mesh.triangles.empty());
  strandmesh::write_mesh(tree, dir / "tree.obj");
  EXPECT_GT(std::filesystem::file_size(dir / "tree.obj"), 0u);
  std::filesystem::remove_all(dir);
}

TEST(Api, ErrorsAreTheLibrarysExceptions) {
  const auto dir = test::temp_dir("api_errors");
  EXPECT_THROW(strandmesh::read_skeleton(dir / "missing.json"), IoError);
  const strandmesh::Skeleton skeleton = test::straight_branch();
  EXPECT_THROW(strandmesh::mesh_skeleton(skeleton, {.threads = -1}), InvalidInputError);
  EXPECT_THROW(strandmesh::mesh_skeleton(skeleton, {.spacing = -1.0}), InvalidInputError);
  EXPECT_THROW(strandmesh::mesh_skeleton(skeleton, {.config = dir / "missing.json"}), IoError);
  // An unknown extension: nothing written.
  const strandmesh::Tree tree = strandmesh::mesh_skeleton(skeleton);
  EXPECT_THROW(strandmesh::write_mesh(tree, dir / "tree.stl"), InvalidInputError);
  EXPECT_FALSE(std::filesystem::exists(dir / "tree.stl"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sm
