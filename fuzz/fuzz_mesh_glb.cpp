// Fuzz target: .glb meshes as `strandmesh check` reads and checks them (meshio/mesh_io.h,
// meshcheck/checks.h), and level 1 of their levels of detail.
#include "fuzz/fuzz_reader.h"
#include "meshcheck/checks.h"
#include "meshio/mesh_io.h"

SM_FUZZ_READER(bytes) {
  const sm::Mesh mesh = sm::parse_mesh(bytes, sm::MeshFormat::glb, "fuzz.glb");
  (void)sm::check_mesh(mesh);
  // A level of detail (MSFT_lod), as `check --lod 1` reads it.
  sm::MeshReadParams level;
  level.lod = 1;
  (void)sm::parse_mesh(bytes, sm::MeshFormat::glb, "fuzz.glb", level);
}
