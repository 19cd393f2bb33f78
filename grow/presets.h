#pragma once
/// Grower presets: GrowerParams as JSON files (`configs/grow/*.json`).
///
/// A preset file is one JSON object whose keys are the GrowerParams field names (see
/// grow/tree_grower.h; docs/growers.md lists them), plus two documentation keys:
///   "description":    what the tree looks like (string),
///   "expected_nodes": [min, max], the node count range the preset is documented to give.
/// Every key is optional: a missing field keeps its GrowerParams default. An unknown key is an
/// error, so a typo never silently falls back to a default. Enums are strings
/// ("mode": "self_organizing" | "space_colonization"; shape "kind": "sphere" | "ellipsoid" |
/// "box" | "cylinder" | "cone" | "mesh"), vectors are [x, y, z] arrays. The crown is
///   "crown": {"shapes": [{...}], "obstacles": [{...}], "voxel_size": m, "shell_thickness": m}
/// with shape keys kind, center, radius, radii, height, top_radius, and for meshes
/// "mesh": "file.obj" (a closed OBJ mesh, relative to the preset file; only v and f lines
/// are read, polygons are fanned into triangles).

#include <cstddef>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "grow/tree_grower.h"

namespace sm {

/// A named parameter set with its documentation.
struct GrowPreset {
  std::string name;                    ///< file name without extension, e.g. "broadleaf"
  std::string description;             ///< what the grown tree looks like
  std::size_t expected_min_nodes = 0;  ///< documented node count range (a count), lower end
  std::size_t expected_max_nodes = 0;  ///< upper end; 0 = not documented
  GrowerParams params;
};

/// Parses a preset from JSON text. `name` is used in error messages and as the preset name;
/// `base_dir` resolves relative mesh paths. Throws InvalidInputError naming the file and the
/// key (unknown keys, wrong types, out-of-range values via validate_grower_params), IoError
/// for an unreadable mesh file.
GrowPreset parse_grow_preset(std::string_view json_text, const std::string& name,
                             const std::filesystem::path& base_dir = {});

/// Reads and parses a preset file (name = file stem). Throws IoError when unreadable.
GrowPreset load_grow_preset(const std::filesystem::path& path);

/// Serializes every parameter (all fields, defaults included) in the preset format; parsing
/// the result gives the same parameters. Mesh shapes are written with their vertices and
/// triangles inline ("mesh_vertices", "mesh_triangles"), which the parser also accepts.
std::string grow_preset_to_json(const GrowPreset& preset);

/// The preset files (*.json) in `dir`, sorted by name; empty when the folder does not exist.
std::vector<std::filesystem::path> list_grow_presets(const std::filesystem::path& dir);

/// Resolves a preset given by name ("broadleaf" → dir/broadleaf.json) or by a path to a
/// .json file. Throws UsageError naming the available presets when there is no such name.
std::filesystem::path find_grow_preset(const std::string& name_or_path, const std::filesystem::path& dir);

}  // namespace sm
