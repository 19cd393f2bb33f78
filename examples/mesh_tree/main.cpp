// mesh_tree SKELETON OUT.{glb,gltf,obj,ply} [SEED]: meshes a tree skeleton with the strandmesh
// library, as `strandmesh mesh SKELETON -o OUT --seed SEED` does.

#include <cstdio>
#include <exception>
#include <string>

#include <strandmesh/strandmesh.h>

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: mesh_tree SKELETON OUT.{glb,gltf,obj,ply} [SEED]\n");
    return 2;
  }
  try {
    const strandmesh::Skeleton skeleton = strandmesh::read_skeleton(argv[1]);
    const strandmesh::Tree tree =
        strandmesh::mesh_skeleton(skeleton, {.seed = argc > 3 ? std::stoull(argv[3]) : 1, .threads = 2});
    for (const std::string& w : tree.warnings) std::fprintf(stderr, "warning: %s\n", w.c_str());
    strandmesh::write_mesh(tree, argv[2]);
    std::printf("%s: %zu triangles, %zu vertices -> %s\n", argv[1], tree.mesh.triangle_count(),
                tree.mesh.vertex_count(), argv[2]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
