// Writes glTF files of fixture meshes into a directory, for the Khronos glTF validator test
// (scripts/validate_gltf.sh): gltf_fixture_writer OUT_DIR

#include <cstdio>
#include <exception>
#include <filesystem>

#include "meshio/export.h"
#include "tests/mesh_fixtures.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: gltf_fixture_writer OUT_DIR\n");
    return 2;
  }
  try {
    const std::filesystem::path dir = argv[1];
    std::filesystem::create_directories(dir);
    using sm::test::capped_tube;
    // Seams (UVs), branch ids, z-up input.
    sm::write_mesh(capped_tube({0, 0, 0}, {0.2, 0.1, 1.5}, 0.1, 24, 12, true, 5), dir / "tube.glb");
    // Georeferenced: a 5 mm twig at UTM-like coordinates (origin in the node translation).
    sm::write_mesh(sm::test::translated(capped_tube({0, 0, 0}, {0, 0.02, 0.3}, 0.005, 12, 6, true, 1),
                                        {512345.678, 5412345.678, 254.0}),
                   dir / "georeferenced.glb");
    // Compressed and quantized (EXT_meshopt_compression, KHR_mesh_quantization), 16-bit indices.
    const sm::Mesh tube = capped_tube({0, 0, 0}, {0.2, 0.1, 1.5}, 0.1, 24, 12, true, 5);
    sm::write_mesh(tube, dir / "tube_meshopt.glb", {.compress = sm::Compression::meshopt});
    sm::write_mesh(tube, dir / "tube_quantized.glb", {.quantize = true});
    sm::write_mesh(tube, dir / "tube_quantized_meshopt.gltf", {.compress = sm::Compression::meshopt, .quantize = true});
    // Levels of detail in one file (MSFT_lod on the scene's node), plain and quantized + meshopt.
    const sm::Mesh lod1 = capped_tube({0, 0, 0}, {0.2, 0.1, 1.5}, 0.1, 12, 6, true, 5);
    const sm::Mesh lod2 = capped_tube({0, 0, 0}, {0.2, 0.1, 1.5}, 0.1, 6, 2, true, 5);
    const sm::ExportLevel levels[] = {{&tube, nullptr}, {&lod1, nullptr}, {&lod2, nullptr}};
    sm::write_mesh_levels(levels, dir / "tube_lods.glb", {});
    sm::write_mesh_levels(levels, dir / "tube_lods_quantized_meshopt.glb",
                          {.compress = sm::Compression::meshopt, .quantize = true});
    // Text glTF with an embedded buffer, y-up input, no UVs or branch ids.
    sm::write_mesh(sm::test::icosphere(3, 0.5), dir / "sphere.gltf", {.up_axis = sm::UpAxis::y});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
