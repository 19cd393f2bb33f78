// Grower presets as JSON. One field list (visit_params) drives both reading and writing, so
// the JSON keys are exactly the GrowerParams field names and cannot drift apart. Unknown keys
// are errors, as in every config file: a file only overrides, and a typo must never fall back
// to a default silently.

#include "grow/presets.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <set>
#include <sstream>
#include <type_traits>

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/file_io.h"
#include "core/input_limits.h"

namespace sm {
namespace {

using nlohmann::json;

const std::array<std::pair<const char*, GrowMode>, 2> kModes{
    {{"self_organizing", GrowMode::self_organizing}, {"space_colonization", GrowMode::space_colonization}}};
const std::array<std::pair<const char*, ShapeKind>, 6> kKinds{{{"sphere", ShapeKind::sphere},
                                                               {"ellipsoid", ShapeKind::ellipsoid},
                                                               {"box", ShapeKind::box},
                                                               {"cylinder", ShapeKind::cylinder},
                                                               {"cone", ShapeKind::cone},
                                                               {"mesh", ShapeKind::mesh}}};

template <class Shape, class V>  // Shape: VolumeShape or const VolumeShape
void visit_shape(Shape& s, V& v) {
  v("kind", s.kind);
  v("center", s.center);
  v("radius", s.radius);
  v("radii", s.radii);
  v("height", s.height);
  v("top_radius", s.top_radius);
}

template <class Crown, class V>
void visit_crown(Crown& c, V& v) {
  v("shapes", c.shapes);
  v("obstacles", c.obstacles);
  v("voxel_size", c.voxel_size);
  v("shell_thickness", c.shell_thickness);
}

/// Every GrowerParams field, in the order of the header (Params: const or not).
template <class Params, class V>
void visit_params(Params& p, V& v) {
  v("mode", p.mode);
  v("seed", p.seed);
  v("crown", p.crown);
  v("attraction_points", p.attraction_points);
  v("internode_length", p.internode_length);
  v("perception_radius", p.perception_radius);
  v("perception_angle_degrees", p.perception_angle_degrees);
  v("occupancy_radius", p.occupancy_radius);
  v("branching_angle_degrees", p.branching_angle_degrees);
  v("phyllotaxis_degrees", p.phyllotaxis_degrees);
  v("inertia", p.inertia);
  v("tropism", p.tropism);
  v("trunk_tropism", p.trunk_tropism);
  v("direction_jitter_degrees", p.direction_jitter_degrees);
  v("apical_control", p.apical_control);
  v("vigor", p.vigor);
  v("max_shoot_internodes", p.max_shoot_internodes);
  v("shadow", p.shadow);
  v("shadow_voxel_size", p.shadow_voxel_size);
  v("shadow_depth", p.shadow_depth);
  v("shadow_a", p.shadow_a);
  v("shadow_b", p.shadow_b);
  v("shadow_full", p.shadow_full);
  v("shadow_steering", p.shadow_steering);
  v("trunk_direction", p.trunk_direction);
  v("trunk_height", p.trunk_height);
  v("max_iterations", p.max_iterations);
  v("max_nodes", p.max_nodes);
  v("tip_radius", p.tip_radius);
  v("pipe_exponent", p.pipe_exponent);
  v("max_turn_degrees", p.max_turn_degrees);
  v("min_branch_angle_degrees", p.min_branch_angle_degrees);
  v("max_branch_angle_degrees", p.max_branch_angle_degrees);
  v("min_edge_ratio", p.min_edge_ratio);
  v("prune_ratio", p.prune_ratio);
}

/// Reads the keys of one JSON object into fields; remembers which keys it knows.
class Reader {
 public:
  Reader(const json& object, std::string file, std::string path, std::filesystem::path base)
      : j_(object), file_(std::move(file)), path_(std::move(path)), base_(std::move(base)) {
    if (!j_.is_object()) fail(path_.empty() ? "the preset must be a JSON object" : "must be a JSON object");
  }

  template <class T>
  void operator()(const char* key, T& out) {
    known_.insert(key);
    const auto it = j_.find(key);
    if (it == j_.end()) return;
    read(*it, child(key), out);
  }

  /// Throws for the first key no visitor asked for.
  void reject_unknown() const {
    for (const auto& [key, value] : j_.items()) {
      if (!known_.count(key)) {
        throw InvalidInputError(file_ + ": unknown key \"" + child(key) + "\"; see docs/growers.md for the keys");
      }
    }
  }
  void allow(const char* key) { known_.insert(key); }

  [[noreturn]] void fail(const std::string& rule, const std::string& at = {}) const {
    const std::string where = at.empty() ? path_ : at;
    throw InvalidInputError(file_ + ": " + (where.empty() ? "" : where + ": ") + rule);
  }

 private:
  [[nodiscard]] std::string child(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

  void read(const json& v, const std::string& at, double& out) const {
    if (!v.is_number()) fail("must be a number", at);
    out = v.get<double>();
    if (!std::isfinite(out)) fail("must be finite", at);
  }
  void read(const json& v, const std::string& at, bool& out) const {
    if (!v.is_boolean()) fail("must be true or false", at);
    out = v.get<bool>();
  }
  template <class T>
  requires std::is_unsigned_v<T>
  void read(const json& v, const std::string& at, T& out) const {
    if (!v.is_number_integer() || (v.is_number_integer() && !v.is_number_unsigned() && v.get<std::int64_t>() < 0)) {
      fail("must be a non-negative integer", at);
    }
    const auto u = v.get<std::uint64_t>();
    if (u > std::numeric_limits<T>::max()) fail("is too large", at);
    out = static_cast<T>(u);
  }
  void read(const json& v, const std::string& at, dvec3& out) const {
    if (!v.is_array() || v.size() != 3) fail("must be an array of three numbers [x, y, z]", at);
    for (std::size_t i = 0; i < 3; ++i) read(v[i], at + "[" + std::to_string(i) + "]", out[static_cast<int>(i)]);
  }
  template <class E, std::size_t N>
  void read_enum(const json& v, const std::string& at, E& out,
                 const std::array<std::pair<const char*, E>, N>& names) const {
    std::string all;
    for (const auto& [name, value] : names) all += std::string(all.empty() ? "" : ", ") + name;
    if (!v.is_string()) fail("must be one of " + all, at);
    const auto s = v.get<std::string>();
    for (const auto& [name, value] : names) {
      if (s == name) {
        out = value;
        return;
      }
    }
    fail("\"" + s + "\" is not one of " + all, at);
  }
  void read(const json& v, const std::string& at, GrowMode& out) const { read_enum(v, at, out, kModes); }
  void read(const json& v, const std::string& at, ShapeKind& out) const { read_enum(v, at, out, kKinds); }
  void read(const json& v, const std::string& at, CrownVolume& out) const {
    Reader r(v, file_, at, base_);
    visit_crown(out, r);
    r.reject_unknown();
  }
  void read(const json& v, const std::string& at, std::vector<VolumeShape>& out) const {
    if (!v.is_array()) fail("must be an array of shapes", at);
    out.clear();
    for (std::size_t i = 0; i < v.size(); ++i) {
      const std::string here = at + "[" + std::to_string(i) + "]";
      Reader r(v[i], file_, here, base_);
      VolumeShape s;
      visit_shape(s, r);
      r.allow("mesh");
      r.allow("mesh_vertices");
      r.allow("mesh_triangles");
      r.reject_unknown();
      read_mesh(v[i], here, s);
      if (s.kind == ShapeKind::mesh && s.mesh_triangles.empty()) {
        fail("a mesh shape needs \"mesh\": \"file.obj\" (or mesh_vertices and mesh_triangles)", here);
      }
      out.push_back(std::move(s));
    }
  }

  void read_mesh(const json& v, const std::string& at, VolumeShape& s) const {
    if (v.contains("mesh")) {
      if (!v["mesh"].is_string()) fail("must be a file name", at + ".mesh");
      const std::filesystem::path file = base_ / v["mesh"].get<std::string>();
      read_obj(read_file(file), file.string(), s);
    }
    if (v.contains("mesh_vertices")) {
      const json& a = v["mesh_vertices"];
      if (!a.is_array()) fail("must be an array of [x, y, z]", at + ".mesh_vertices");
      for (std::size_t i = 0; i < a.size(); ++i) {
        dvec3 p;
        read(a[i], at + ".mesh_vertices[" + std::to_string(i) + "]", p);
        s.mesh_vertices.push_back(p);
      }
    }
    if (v.contains("mesh_triangles")) {
      const json& a = v["mesh_triangles"];
      if (!a.is_array()) fail("must be an array of [i, j, k]", at + ".mesh_triangles");
      for (std::size_t i = 0; i < a.size(); ++i) {
        const std::string here = at + ".mesh_triangles[" + std::to_string(i) + "]";
        if (!a[i].is_array() || a[i].size() != 3) fail("must be three vertex indices", here);
        std::array<std::uint32_t, 3> t{};
        for (std::size_t k = 0; k < 3; ++k) read(a[i][k], here, t[k]);
        s.mesh_triangles.push_back(t);
      }
    }
  }

  /// Minimal OBJ reader: "v x y z" and "f a b c ..." (a may be "a/t/n", negative = relative).
  static void read_obj(const std::string& text, const std::string& name, VolumeShape& s) {
    std::istringstream in(text);
    std::string line;
    std::size_t line_no = 0;
    const std::size_t first = s.mesh_vertices.size();
    while (std::getline(in, line)) {
      ++line_no;
      std::istringstream ls(line);
      std::string tag;
      ls >> tag;
      if (tag == "v") {
        dvec3 p;
        if (!(ls >> p.x >> p.y >> p.z)) {
          throw InvalidInputError(name + ":" + std::to_string(line_no) + ": a vertex needs three numbers");
        }
        s.mesh_vertices.push_back(p);
      } else if (tag == "f") {
        std::vector<std::uint32_t> face;
        std::string tok;
        while (ls >> tok) {
          long idx = 0;
          try {
            idx = std::stol(tok.substr(0, tok.find('/')));
          } catch (const std::exception&) {
            throw InvalidInputError(name + ":" + std::to_string(line_no) + ": bad face index \"" + tok + "\"");
          }
          const long count = static_cast<long>(s.mesh_vertices.size() - first);
          const long k = idx > 0 ? idx - 1 : count + idx;
          if (idx == 0 || k < 0 || k >= count) {
            throw InvalidInputError(name + ":" + std::to_string(line_no) + ": face index " + tok +
                                    " refers to no vertex");
          }
          face.push_back(static_cast<std::uint32_t>(first + static_cast<std::size_t>(k)));
        }
        if (face.size() < 3) {
          throw InvalidInputError(name + ":" + std::to_string(line_no) + ": a face needs at least three vertices");
        }
        for (std::size_t k = 1; k + 1 < face.size(); ++k) s.mesh_triangles.push_back({face[0], face[k], face[k + 1]});
      }
    }
  }

  const json& j_;
  std::string file_, path_;
  std::filesystem::path base_;
  std::set<std::string> known_;
};

/// Writes fields into a JSON object.
class Writer {
 public:
  json j = json::object();

  template <class T>
  void operator()(const char* key, const T& value) {
    j[key] = write(value);
  }

 private:
  static json write(double v) { return v; }
  static json write(bool v) { return v; }
  template <class T>
  requires std::is_unsigned_v<T>
  static json write(T v) { return static_cast<std::uint64_t>(v); }
  static json write(const dvec3& v) { return json::array({v.x, v.y, v.z}); }
  static json write(GrowMode m) {
    for (const auto& [name, value] : kModes) {
      if (value == m) return name;
    }
    return "?";
  }
  static json write(ShapeKind k) {
    for (const auto& [name, value] : kKinds) {
      if (value == k) return name;
    }
    return "?";
  }
  static json write(const CrownVolume& c) {
    Writer w;
    visit_crown(c, w);
    return w.j;
  }
  static json write(const std::vector<VolumeShape>& shapes) {
    json a = json::array();
    for (const auto& s : shapes) {
      Writer w;
      visit_shape(s, w);
      if (s.kind == ShapeKind::mesh) {
        json v = json::array(), t = json::array();
        for (const auto& p : s.mesh_vertices) v.push_back(write(p));
        for (const auto& f : s.mesh_triangles) t.push_back(json::array({f[0], f[1], f[2]}));
        w.j["mesh_vertices"] = v;
        w.j["mesh_triangles"] = t;
      }
      a.push_back(w.j);
    }
    return a;
  }
};

}  // namespace

GrowPreset parse_grow_preset(std::string_view text, const std::string& name, const std::filesystem::path& base_dir) {
  check_json_nesting(text, name);
  json j;
  try {
    j = json::parse(text);
  } catch (const json::parse_error& e) {
    throw InvalidInputError(name + ": not valid JSON (" + std::string(e.what()) + ")");
  } catch (const json::exception& e) {  // a number overflow (out_of_range.406) carries no position
    const std::string place = json_error_line_col(text);
    throw InvalidInputError(name + (place.empty() ? "" : ":" + place) + ": not valid JSON (" + std::string(e.what()) + ")");
  }
  GrowPreset preset;
  preset.name = std::filesystem::path(name).stem().string();
  Reader r(j, name, "", base_dir);
  visit_params(preset.params, r);
  r.allow("description");
  r.allow("expected_nodes");
  r.reject_unknown();
  if (j.contains("description")) {
    if (!j["description"].is_string()) r.fail("must be a string", "description");
    preset.description = j["description"].get<std::string>();
  }
  if (j.contains("expected_nodes")) {
    const json& e = j["expected_nodes"];
    if (!e.is_array() || e.size() != 2 || !e[0].is_number_unsigned() || !e[1].is_number_unsigned() ||
        e[0].get<std::uint64_t>() > e[1].get<std::uint64_t>()) {
      r.fail("must be [min, max] with 0 <= min <= max", "expected_nodes");
    }
    preset.expected_min_nodes = e[0].get<std::size_t>();
    preset.expected_max_nodes = e[1].get<std::size_t>();
  }
  try {
    validate_grower_params(preset.params);
    const Volume check(preset.params.crown);
  } catch (const InvalidInputError& e) {
    throw InvalidInputError(name + ": " + e.what());
  }
  return preset;
}

GrowPreset load_grow_preset(const std::filesystem::path& path) {
  return parse_grow_preset(read_file(path), path.string(), path.parent_path());
}

std::string grow_preset_to_json(const GrowPreset& preset) {
  Writer w;
  w.j["description"] = preset.description;
  w.j["expected_nodes"] = json::array({preset.expected_min_nodes, preset.expected_max_nodes});
  visit_params(preset.params, w);
  return w.j.dump(2) + "\n";
}

std::vector<std::filesystem::path> list_grow_presets(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> out;
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return out;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    if (e.is_regular_file() && e.path().extension() == ".json") out.push_back(e.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::filesystem::path find_grow_preset(const std::string& name_or_path, const std::filesystem::path& dir) {
  const std::filesystem::path given(name_or_path);
  if (given.extension() == ".json" || name_or_path.find('/') != std::string::npos) return given;
  const std::filesystem::path file = dir / (name_or_path + ".json");
  std::error_code ec;
  if (std::filesystem::is_regular_file(file, ec)) return file;
  std::string names;
  for (const auto& p : list_grow_presets(dir)) names += (names.empty() ? "" : ", ") + p.stem().string();
  throw UsageError("no grow preset named \"" + name_or_path + "\" in " + dir.string() +
                   (names.empty() ? "" : "; available: " + names));
}

}  // namespace sm
