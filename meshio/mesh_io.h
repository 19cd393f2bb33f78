#pragma once
/// Reading triangle meshes (.glb, .gltf, .obj, .ply) into a welded Mesh, for `strandmesh check`,
/// the viewer and round-trip tests.
///
/// What is read:
///  - glTF 2.0 (.glb binary, .gltf text with embedded `data:` or external buffers beside the
///    file): every triangle primitive (mode TRIANGLES) of the default scene's node tree (or of
///    every mesh when there is no scene), with the node transforms applied; POSITION (float),
///    NORMAL (float), TEXCOORD_0 (float or normalized unsigned byte/short) and `_BRANCH_ID`
///    (float or unsigned byte/short, per vertex; a triangle takes its first corner's id); indices
///    unsigned byte/short/int or none. With MeshReadParams::lod = k > 0, the node tree of the
///    k-th id of the `MSFT_lod` extension on the scene's node instead (levels of detail).
///  - OBJ: `v` (extra components such as w or colours ignored), `vt`, `vn`, `f` with `v`, `v/vt`,
///    `v//vn`, `v/vt/vn` corners and negative (relative) indices; polygons are fan-triangulated;
///    other statements (`o`, `g`, `s`, `usemtl`, `mtllib`, `l`, ...) are ignored.
///  - PLY: ascii, binary_little_endian and binary_big_endian; vertex x, y, z (any numeric
///    type), optional nx, ny, nz and texture coordinates (s/t, u/v, texture_u/texture_v); face
///    list `vertex_indices` (or `vertex_index`) fan-triangulated, optional per-corner list
///    `texcoord`; other elements and properties are skipped.
///  Placement: the up axis, pivot and units strandmesh recorded in a file it wrote
///  (meshio/placement.h) are undone, so the result is in metres, in the mesh's original frame,
///  with up axis `up_axis`; a glTF file without the record is taken as y-up in metres, an OBJ
///  or PLY file without it is kept as it is (no up-axis conversion).
///
/// Welding: vertices with exactly equal positions (bit for bit, +0 and -0 equal) become one
/// vertex, in order of first appearance in the file, so a file written with seams split comes
/// back welded and the topology checks work on it. UVs are stored per corner; a welded vertex
/// takes the normal of its first copy. `normals` is filled only when every vertex used by a
/// triangle has one, `corner_uvs` only when every corner has one; `corner_normals` (each
/// corner's copy's normal) only when, besides, the copies of some vertex have different
/// normals (smoothing groups split at creases). `vertex_strand` and
/// `vertex_node` are left empty (no format stores them).
///
/// Errors: IoError when the file cannot be read; InvalidInputError naming the file (and line
/// or element) and the rule for malformed content (truncated data, indices out of range,
/// non-numeric values, unsupported encodings); an unknown extension is an InvalidInputError
/// listing the accepted ones. Never crashes on garbage.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/mesh.h"
#include "meshio/export.h"
#include "skeleton/skeleton.h"

namespace sm {

/// Options of the mesh readers.
struct MeshReadParams {
  UpAxis up_axis = UpAxis::z;    ///< up axis wanted in the result (default z)
  bool file_coordinates = false;  ///< keep the file's own coordinates: no placement undone, no axes changed (default false)
  std::uint32_t lod = 0;          ///< glTF: the level of detail to read (MSFT_lod; 0 the scene itself, the finest) (default 0)
};

/// Reads the mesh file at `path`; the format is taken from the extension.
Mesh read_mesh(const std::filesystem::path& path, const MeshReadParams& params = {});

/// Parses the bytes of a mesh file in `format`. `source` names the file in messages and is the
/// base for a .gltf's external buffer URIs.
Mesh parse_mesh(std::string_view bytes, MeshFormat format, const std::filesystem::path& source,
                const MeshReadParams& params = {});

}  // namespace sm
