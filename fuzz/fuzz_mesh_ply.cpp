// Fuzz target: .ply meshes as `strandmesh check` reads and checks them (meshio/mesh_io.h,
// meshcheck/checks.h).
#include "fuzz/fuzz_reader.h"
#include "meshcheck/checks.h"
#include "meshio/mesh_io.h"

SM_FUZZ_READER(bytes) {
  const sm::Mesh mesh = sm::parse_mesh(bytes, sm::MeshFormat::ply, "fuzz.ply");
  (void)sm::check_mesh(mesh);
}
