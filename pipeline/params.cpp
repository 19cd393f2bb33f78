// Parameter files: every Params field by name, reading with strict key checks, writing all.

#include <map>
#include <limits>
#include <set>

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/file_io.h"
#include "core/input_limits.h"
#include "meshio/export_json.h"
#include "pipeline/pipeline.h"

namespace sm {
namespace {

using nlohmann::json;

// One visit_fields per Params struct: the single list of its configurable fields.
template <class V>
void visit_fields(SkeletonParams& p, V&& v) {
  v("max_nodes", p.max_nodes);
  v("merge_edge_ratio", p.merge_edge_ratio);
  v("radius_floor", p.radius_floor);
  v("max_child_ratio", p.max_child_ratio);
  v("thick_child_policy", p.thick_child_policy);
  v("max_edge_ratio", p.max_edge_ratio);
  v("binarize_step_ratio", p.binarize_step_ratio);
  v("max_chain_forks", p.max_chain_forks);
  v("merge_inner_branches", p.merge_inner_branches);
  v("collar_ratio", p.collar_ratio);
  v("collar_max_child_ratio", p.collar_max_child_ratio);
  v("collar_min_stub", p.collar_min_stub);
  v("max_lateral_angle", p.max_lateral_angle);
  v("max_turn_back", p.max_turn_back);
  v("tight_bend_ratio", p.tight_bend_ratio);
  v("separate", p.separate);
  v("max_node_move", p.max_node_move);
  v("branch_clearance", p.branch_clearance);
}
template <class V>
void visit_fields(ParticleParams& p, V&& v) {
  v("spacing", p.spacing);
  v("root_strands", p.root_strands);
  v("max_root_strands", p.max_root_strands);
  v("min_particles", p.min_particles);
  v("new_strand_sparsity", p.new_strand_sparsity);
  v("wall_margin", p.wall_margin);
  v("wall_offset", p.wall_offset);
  v("max_steps", p.max_steps);
  v("move_tolerance", p.move_tolerance);
  v("max_velocity", p.max_velocity);
  v("damping", p.damping);
  v("step_size", p.step_size);
  v("repulsion_radius", p.repulsion_radius);
  v("neighbour_skin", p.neighbour_skin);
  v("rebuild_every", p.rebuild_every);
  v("fork_gap", p.fork_gap);
  v("max_total_particles", p.max_total_particles);
  v("seed", p.seed);
}
template <class V>
void visit_fields(StrandParams& p, V&& v) {
  v("alpha", p.alpha);
}
template <class V>
void visit_fields(ContourParams& p, V&& v) {
  v("ring_edge", p.ring_edge);
  v("min_ring_vertices", p.min_ring_vertices);
  v("resolution", p.resolution);
  v("slice_step", p.slice_step);
  v("min_slice_step", p.min_slice_step);
  v("max_slices_per_edge", p.max_slices_per_edge);
  v("max_corner_cut", p.max_corner_cut);
  v("split_gap", p.split_gap);
  v("thin_gap_radii", p.thin_gap_radii);
  v("fork_transition", p.fork_transition);
  v("min_fused_length", p.min_fused_length);
  v("split_nested_laterals", p.split_nested_laterals);
  v("split_bisection_steps", p.split_bisection_steps);
  v("concave_turn_degrees", p.concave_turn_degrees);
  v("fallback_max_edge", p.fallback_max_edge);
}
template <class V>
void visit_fields(RepairParams& p, V&& v) {
  v("self_union", p.self_union);
  v("max_rounds", p.max_rounds);
  v("fold_rounds", p.fold_rounds);
  v("fold_max_move", p.fold_max_move);
  v("count_pairs_up_to", p.count_pairs_up_to);
}
template <class V>
void visit_fields(MeshParams& p, V&& v) {
  v("tip_dome", p.tip_dome);
  v("uv_repeat_u", p.uv_repeat_u);
  v("uvs", p.uvs);
  v("normals", p.normals);
  v("merge_stacked_junctions", p.merge_stacked_junctions);
  v("fold_repair_rounds", p.fold_repair_rounds);
  v("fold_repair_max_move", p.fold_repair_max_move);
  v("fold_repair_collapses", p.fold_repair_collapses);
  v("fold_repair_refills", p.fold_repair_refills);
  v("fold_repair_variants", p.fold_repair_variants);
  v("count_pairs_up_to", p.count_pairs_up_to);
  v("fork_retry", p.fork_retry);
  v("outer_surface", p.outer_surface);
  v("cover_near_misses", p.cover_near_misses);
}

const std::map<std::string, ThickChildPolicy> kPolicies{
    {"clamp_child", ThickChildPolicy::clamp_child},
    {"raise_parent", ThickChildPolicy::raise_parent},
    {"keep", ThickChildPolicy::keep}};

struct Reader {
  const json& section;
  std::string where;  // "config.json: particles"
  std::set<std::string> known;

  void operator()(const char* key, double& x) {
    known.insert(key);
    if (auto it = section.find(key); it != section.end()) {
      if (!it->is_number()) fail(key, "a number", *it);
      x = it->get<double>();
      if (!std::isfinite(x)) throw InvalidInputError(where + "." + key + ": must be finite");
    }
  }
  template <class I>
    requires std::is_integral_v<I> && (!std::is_same_v<I, bool>)
  void operator()(const char* key, I& x) {
    known.insert(key);
    if (auto it = section.find(key); it != section.end()) {
      // (No wrap-around: a value beyond the field's type is an error, not taken modulo 2^32.)
      const auto max = static_cast<std::uint64_t>(std::numeric_limits<I>::max());
      if (it->is_number_unsigned() && it->get<std::uint64_t>() <= max) {
        x = static_cast<I>(it->get<std::uint64_t>());
      } else if (it->is_number_integer() && it->get<std::int64_t>() >= 0 &&
                 static_cast<std::uint64_t>(it->get<std::int64_t>()) <= max) {
        x = static_cast<I>(it->get<std::int64_t>());
      } else {
        fail(key, ("a non-negative integer up to " + std::to_string(max)).c_str(), *it);
      }
    }
  }
  void operator()(const char* key, bool& x) {
    known.insert(key);
    if (auto it = section.find(key); it != section.end()) {
      if (!it->is_boolean()) fail(key, "true or false", *it);
      x = it->get<bool>();
    }
  }
  void operator()(const char* key, ThickChildPolicy& x) {
    known.insert(key);
    if (auto it = section.find(key); it != section.end()) {
      const auto p = it->is_string() ? kPolicies.find(it->get<std::string>()) : kPolicies.end();
      if (p == kPolicies.end()) fail(key, "\"clamp_child\", \"raise_parent\" or \"keep\"", *it);
      x = p->second;
    }
  }
  [[noreturn]] void fail(const char* key, const char* what, const json& value) const {
    throw InvalidInputError(where + "." + key + ": must be " + what + ", not " + excerpt(value.dump()));
  }
  void check_unknown() const {
    for (auto it = section.begin(); it != section.end(); ++it) {
      if (!known.count(it.key())) {
        std::string list;
        for (const auto& k : known) list += (list.empty() ? "" : ", ") + k;
        throw InvalidInputError(where + ": unknown key \"" + excerpt(it.key()) + "\" (known keys: " + list + ")");
      }
    }
  }
};

struct Writer {
  json& out;
  template <class T>
  void operator()(const char* key, T& x) {
    out[key] = x;
  }
  void operator()(const char* key, ThickChildPolicy& x) {
    for (const auto& [name, value] : kPolicies) {
      if (value == x) out[key] = name;
    }
  }
};

template <class P>
void read_section(const json& doc, const char* name, const std::string& file, P& params) {
  auto it = doc.find(name);
  if (it == doc.end()) return;
  if (!it->is_object()) throw InvalidInputError(file + ": \"" + name + "\" must be an object");
  Reader r{*it, file + ": " + name, {}};
  visit_fields(params, r);
  r.check_unknown();
}

template <class P>
json write_section(P params) {
  json j = json::object();
  Writer w{j};
  visit_fields(params, w);
  return j;
}

}  // namespace

PipelineParams parse_params_json(std::string_view text, const std::string& name, const PipelineParams& base) {
  check_json_nesting(text, name);
  json doc;
  try {
    doc = json::parse(text.begin(), text.end());
  } catch (const json::exception& e) {
    std::string what = e.what();
    const auto bracket = what.find("] ");
    throw InvalidInputError(name + ": not valid JSON: " + (bracket != std::string::npos ? what.substr(bracket + 2) : what));
  }
  if (!doc.is_object()) throw InvalidInputError(name + ": a config file must be a JSON object");
  static const std::set<std::string> sections{"skeleton", "particles", "strands", "contours", "meshing", "repair"};
  for (auto it = doc.begin(); it != doc.end(); ++it) {
    if (!sections.count(it.key()) && it.key() != "comment" && it.key() != "description" && it.key() != "export") {
      throw InvalidInputError(name + ": unknown section \"" + excerpt(it.key()) +
                              "\" (known: skeleton, particles, strands, contours, meshing, repair, export, description)");
    }
  }
  PipelineParams p = base;
  read_section(doc, "skeleton", name, p.skeleton);
  read_section(doc, "particles", name, p.particles);
  read_section(doc, "strands", name, p.strands);
  read_section(doc, "contours", name, p.contours);
  read_section(doc, "meshing", name, p.meshing);
  read_section(doc, "repair", name, p.repair);
  // The writer's options (not a stage): their own reader, meshio/export_json.h.
  if (const auto it = doc.find("export"); it != doc.end()) read_export_json(*it, name + ": export", p.output);
  // Values out of range, named with the file (the stages check them again).
  try {
    validate_params(p.skeleton);
    validate_params(p.contours);
    validate_params(p.meshing);
    validate_params(p.repair);
  } catch (const InvalidInputError& e) {
    throw InvalidInputError(name + ": " + e.what());
  }
  return p;
}

PipelineParams load_params(const std::filesystem::path& path, const PipelineParams& base) {
  return parse_params_json(read_file(path), path.string(), base);
}

std::string params_to_json(const PipelineParams& p) {
  json doc;
  doc["skeleton"] = write_section(p.skeleton);
  doc["particles"] = write_section(p.particles);
  doc["strands"] = write_section(p.strands);
  doc["contours"] = write_section(p.contours);
  doc["meshing"] = write_section(p.meshing);
  doc["repair"] = write_section(p.repair);
  doc["export"] = export_to_json(p.output);
  return doc.dump(2) + "\n";
}

}  // namespace sm
