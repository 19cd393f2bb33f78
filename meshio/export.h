#pragma once
/// Writing a Mesh as glTF 2.0 (.glb, .gltf), Wavefront OBJ or PLY.
///
/// All writers take the welded `Mesh` (core/mesh.h) and split a vertex only where its corners
/// disagree on an attribute that is stored per vertex in the file: the UV (per-corner UVs
/// at seams), the normal (Mesh::corner_normals, where a fan is split into smoothing groups at
/// creases) and, when `_BRANCH_ID` is written, the branch id of the triangle. Positions are
/// per vertex and never cause a split, nor do normals of a mesh without corner normals.
/// Vertices no triangle uses are dropped. The output is deterministic: the same mesh and params give the same bytes.
///
/// Formats (chosen by the file extension, case-insensitive):
///  - `.glb`: binary glTF 2.0, one buffer in the BIN chunk.
///  - `.gltf`: text glTF 2.0 with the buffer embedded as a base64 `data:` URI (one
///    self-contained file, nothing written beside it).
///  Both: one scene, one node, one mesh with one triangle primitive and a default
///  metallic-roughness material (bark brown, double-sided false). Attributes: POSITION
///  (float, with min/max), NORMAL (float, unit), TEXCOORD_0 (float, when the mesh has UVs),
///  `_BRANCH_ID` (float scalar, exact for ids up to 2^24; glTF forbids unsigned int vertex
///  attributes; written when the mesh has branch ids and `branch_ids` is set; a larger id
///  throws InvalidInputError), indices as unsigned int. The Khronos glTF Validator reports no
///  errors or warnings on these files (one info: TEXCOORD_0 is unused by the untextured
///  material); `scripts/validate_gltf.sh` runs it.
///  Placement (ExportParams: up axis, pivot, scale; meshio/placement.h): the file's up axis is
///  the format's convention unless asked otherwise (glTF and OBJ y-up, PLY the input's; z-up
///  (x, y, z) becomes y-up (x, z, -y), a rotation, so triangles keep their orientation); the
///  pivot becomes the file's origin (root, the base of the trunk, for glTF and OBJ; the input's
///  origin for PLY). glTF keeps the pivot in double precision in the node's translation and
///  stores positions as float32 offsets from it, so a georeferenced tree keeps float32's
///  relative precision of about 1e-7 of the tree's size instead of the coordinates' size. The
///  placement is recorded in the file and the readers (mesh_io.h) undo it.
///  - `.obj`: `v x y z`, `vt u v`, `vn x y z`, `f a/a/a ...` with 1-based indices, numbers
///    printed with 9 significant digits (`%.9g`, enough to round-trip float32 and sub-millimetre
///    for coordinates below 10 km).
///  - `.ply`: binary little endian; vertex x, y, z as double (precision of the input kept),
///    nx, ny, nz and s, t as float; face `list uchar uint vertex_indices`.
///  OBJ and PLY say their up axis, units and pivot in a comment line.
///
/// Errors: an unknown extension throws InvalidInputError naming it and the accepted ones; a
/// file that cannot be written throws IoError. Files are written atomically (core/file_io.h):
/// on any failure no file (and no partial file) is left under the requested name.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "core/mesh.h"
#include "core/param_table.h"
#include "core/progress.h"
#include "meshio/placement.h"
#include "skeleton/skeleton.h"

namespace sm {

/// Output file formats.
enum class MeshFormat { glb, gltf, obj, ply };

/// What becomes the origin of the written file (the pivot a DCC tool or engine rotates,
/// scales and places the tree about).
enum class Pivot {
  root,    ///< the base of the trunk (ExportParams::root): the tree stands on the origin
  center,  ///< the centre of the bounding box
  origin   ///< the input's own origin: coordinates as given (georeferenced trees keep theirs)
};

/// glTF buffer compression.
enum class Compression {
  none,    ///< plain buffers
  meshopt  ///< EXT_meshopt_compression (meshoptimizer's vertex and index codecs; three.js MeshoptDecoder)
};

/// Options of the mesh writers.
struct ExportParams {
  UpAxis up_axis = UpAxis::z;          ///< up axis of the mesh coordinates, the input's (default z)
  std::optional<UpAxis> file_up_axis{};///< up axis written (default: the format's: y for glTF and OBJ, the mesh's for PLY)
  std::optional<Pivot> pivot{};        ///< the file's origin (default: root for glTF and OBJ, origin for PLY)
  std::optional<glm::dvec3> root{};    ///< base of the trunk, mesh coordinates in metres (default: bottom centre of the bounds)
  double scale = 1.0;                  ///< file units per metre, > 0 (default 1; 100 writes centimetres)
  bool normals = true;         ///< write normals: Mesh::corner_normals, else Mesh::normals, else angle-weighted ones (default true)
  bool uvs = true;             ///< write texture coordinates when the mesh has corner UVs (default true)
  bool branch_ids = true;      ///< glTF: write `_BRANCH_ID` when the mesh has triangle branch ids (default true)
  bool optimize = true;        ///< meshoptimizer vertex-cache and vertex-fetch order (default true)
  // glTF vertex attributes for wind and shading (docs/export.md); all need `skeleton`.
  bool branch_level = false;      ///< `_BRANCH_LEVEL`: 0 trunk, 1 its laterals, ... (default false)
  bool root_distance = false;     ///< `_ROOT_DISTANCE`: along the tree from the root, file units (default false)
  bool branch_pivot = false;      ///< `_BRANCH_PIVOT`: where the vertex's branch leaves its parent, file frame (default false)
  bool branch_direction = false;  ///< `_BRANCH_DIRECTION`: unit direction there (default false)
  bool branch_phase = false;      ///< `_BRANCH_PHASE`: random in [0, 1) per branch (default false)
  bool thickness = false;         ///< `_THICKNESS`: skeleton radius at the vertex, file units (default false)
  bool color = false;             ///< COLOR_0 = (root distance, thickness, phase, level), each over its maximum (default false)
  bool uv1 = false;               ///< TEXCOORD_1 = (root distance, thickness) in file units (default false)
  bool tangents = false;          ///< TANGENT from the UVs (u around the branch), w the handedness (default false)
  std::uint32_t lods = 1;  ///< levels of detail `strandmesh mesh` writes, the full mesh included (lod/lod.h; default 1: none)
  bool lod_files = false;  ///< `strandmesh mesh`: each level in a file of its own (OUT_lodK.EXT) rather than one glTF file with MSFT_lod (default false; OBJ and PLY always)
  const Skeleton* skeleton = nullptr;  ///< the skeleton the mesh was made from (not owned; for the attributes above)
  Compression compress = Compression::none;  ///< glTF: buffer compression (default none)
  bool quantize = false;       ///< glTF: KHR_mesh_quantization, 16-bit positions and 8-bit normals (default false)
};

/// The config key, accepted values, unit and help of each key of the config's `export` section
/// (core/param_table.h; meshio/param_table.cpp): the file's up axis, pivot, scale, attributes,
/// optimize, compression, quantization and levels of detail. The mesh's own up axis, root and
/// skeleton are set by the caller, not by configs.
const ParamTable<ExportParams>& param_table(std::type_identity<ExportParams>);

/// The up axis, pivot and scale `params` give a file of `format` for `mesh`: the map from mesh
/// to file coordinates (meshio/placement.h). The pivot is put on the export grid (core/mesh.h
/// export_grid_spacing) so that float32 offsets from it stay exact.
Placement export_placement(const Mesh& mesh, MeshFormat format, const ExportParams& params = {});

/// The vertex buffers an exporter writes: the welded mesh with vertices split at seams.
/// Every array has #V' entries (#V' >= number of used welded vertices), `indices` has 3 #F.
struct ExportBuffers {
  std::vector<glm::dvec3> positions;         ///< #V' positions, input axes (metres)
  std::vector<glm::vec3> normals;            ///< #V' unit normals, or empty when not written
  std::vector<glm::vec2> uvs;                ///< #V' texture coordinates, or empty
  std::vector<std::uint32_t> branch;         ///< #V' branch id, or empty
  std::vector<std::uint32_t> source_vertex;  ///< #V' welded vertex each one was copied from ("birth index")
  std::vector<std::uint32_t> indices;        ///< 3 #F vertex indices, CCW seen from outside
};

/// Splits the welded mesh into export buffers (see the file comment for when a vertex is
/// split). Without `params.optimize`, triangles keep their order and the copies of each
/// welded vertex follow the welded order, so a mesh without seams keeps its vertex order
/// (minus unused vertices). Throws InvalidInputError when a triangle index is out of range
/// or an attribute array has the wrong length.
ExportBuffers build_export_buffers(const Mesh& mesh, const ExportParams& params = {});

/// The format for a path's extension. Throws InvalidInputError for any other extension.
MeshFormat mesh_format_from_path(const std::filesystem::path& path);

/// The bytes of the file `write_mesh` would write in `format`.
std::string encode_mesh(const Mesh& mesh, MeshFormat format, const ExportParams& params = {});

/// One level of detail of a tree for write_mesh_levels: its mesh and the skeleton it was made
/// from (for the tree attributes; may differ between levels, which prune twigs).
struct ExportLevel {
  const Mesh* mesh = nullptr;
  const Skeleton* skeleton = nullptr;
};

/// Levels of detail in one glTF file (.glb or .gltf), finest first: one mesh and node per
/// level ("tree", "tree_lod1", ...), all placed by level 0 (the same pivot). Node "tree" is
/// the scene's only node and carries the `MSFT_lod` extension (`ids`: the other levels' nodes,
/// coarser and coarser) and `extras.MSFT_screencoverage` (per level, the screen coverage it is
/// shown down to: half the next level's share of level 0's triangles; 0 for the last, never
/// culled). The extension is used, not required: a client without it shows level 0, the whole
/// tree. Each level has its own buffers (split, quantized, compressed as ExportParams says).
/// One level gives write_mesh's file. Throws InvalidInputError for more than one level in an
/// OBJ or PLY file.
void write_mesh_levels(std::span<const ExportLevel> levels, const std::filesystem::path& path,
                       const ExportParams& params, const ProgressFn& progress = {});
/// The bytes write_mesh_levels would write in `format`.
std::string encode_mesh_levels(std::span<const ExportLevel> levels, MeshFormat format, const ExportParams& params = {});

/// Writes the mesh to `path` in the format given by its extension, atomically.
/// Throws InvalidInputError (unknown extension, invalid mesh) or IoError (cannot write).
void write_mesh(const Mesh& mesh, const std::filesystem::path& path, const ExportParams& params = {});
/// The same, reporting ("export", fraction of the bytes written) to `progress` as it goes.
void write_mesh(const Mesh& mesh, const std::filesystem::path& path, const ExportParams& params,
                const ProgressFn& progress);

}  // namespace sm
