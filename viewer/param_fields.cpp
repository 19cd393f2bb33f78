// The parameter table behind the stage panels. Help texts repeat the one-line comments of the
// Params headers (units included) so the panels explain each slider where it is used.

#include "viewer/param_fields.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <nlohmann/json.hpp>

namespace sm::viewer {

namespace {

template <class T>
T clamp_to(double v) {
  if (std::isnan(v)) return T{};
  const double lo = static_cast<double>(std::numeric_limits<T>::min());
  const double hi = static_cast<double>(std::numeric_limits<T>::max());
  if (v <= lo) return std::numeric_limits<T>::min();
  if (v >= hi) return std::numeric_limits<T>::max();
  return static_cast<T>(std::llround(v));
}

std::vector<ParamField> skeleton_fields(SkeletonParams& p) {
  return {
      {.key = "max_nodes",
       .help = "largest accepted node count (count)",
       .value = SizeRef{&p.max_nodes},
       .min = 1,
       .max = 2e7,
       .logarithmic = true},
      {.key = "merge_edge_ratio",
       .help = "edges shorter than this x the larger radius are merged (relative to the radius)",
       .value = &p.merge_edge_ratio,
       .min = 0,
       .max = 1},
      {.key = "radius_floor",
       .help = "radius floor (metres; 0 = automatic)",
       .value = &p.radius_floor,
       .min = 0,
       .max = 0.05},
      {.key = "max_child_ratio",
       .help = "a child may be this many times as thick as its parent before the policy applies",
       .value = &p.max_child_ratio,
       .min = 0.5,
       .max = 3},
      {.key = "thick_child_policy",
       .help = "what to do with a child thicker than its parent",
       .value = &p.thick_child_policy,
       .min = 0,
       .max = 2},
      {.key = "max_edge_ratio",
       .help = "edges longer than this x the radius are split (relative; 0 = off)",
       .value = &p.max_edge_ratio,
       .min = 0,
       .max = 50},
      {.key = "binarize_step_ratio",
       .help = "step between the extra nodes of an n-ary node (relative to the radius)",
       .value = &p.binarize_step_ratio,
       .min = 0.001,
       .max = 0.5,
       .logarithmic = true},
      {.key = "max_chain_forks",
       .help = "hubs with more children get cluster nodes (0 = off)",
       .value = SizeRef{&p.max_chain_forks},
       .min = 0,
       .max = 64},
      {.key = "merge_inner_branches",
       .help = "fold branches that run inside a sibling's edge into it",
       .value = &p.merge_inner_branches,
       .min = 0,
       .max = 1},
      {.key = "max_lateral_angle",
       .help = "steeper laterals get an upturned base node (degrees from the parent's direction; 0 = off)",
       .value = &p.max_lateral_angle,
       .min = 0,
       .max = 180},
      {.key = "max_turn_back",
       .help = "a child turning back more than this from its node's incoming edge is re-attached below it (degrees; 0 "
               "= off)",
       .value = &p.max_turn_back,
       .min = 0,
       .max = 180},
      {.key = "tight_bend_ratio",
       .help = "a one-child node is removed where r tan(turn/2) exceeds this fraction of its shorter edge (0 = off)",
       .value = &p.tight_bend_ratio,
       .min = 0,
       .max = 4},
      {.key = "collar_ratio",
       .help = "collar node of a thin lateral at this distance from the fork (relative to its radius; 0 = off)",
       .value = &p.collar_ratio,
       .min = 0,
       .max = 3},
      {.key = "collar_max_child_ratio",
       .help = "only laterals thinner than this fraction of the fork's radius get a collar",
       .value = &p.collar_max_child_ratio,
       .min = 0,
       .max = 1},
      {.key = "separate",
       .help = "opt-in shape edits: swing crossing branches apart, re-attach hairpins, remove tight bends",
       .value = &p.separate,
       .min = 0,
       .max = 1},
      {.key = "max_node_move",
       .help = "largest move of an input node by sanitizing (relative to its radius)",
       .value = &p.max_node_move,
       .min = 0,
       .max = 1},
      {.key = "branch_clearance",
       .help = "gap left between separated branches (relative to the sum of their radii)",
       .value = &p.branch_clearance,
       .min = 0,
       .max = 1},
  };
}

std::vector<ParamField> particle_fields(ParticleParams& p) {
  return {
      {.key = "spacing",
       .help = "particle spacing s (metres; 0 = derived)",
       .value = &p.spacing,
       .min = 0,
       .max = 0.05},
      {.key = "root_strands",
       .help = "with spacing 0: choose s so the root has about this many strands (0 = rule)",
       .value = &p.root_strands,
       .min = 0,
       .max = 20000},
      {.key = "max_root_strands",
       .help = "upper bound on the root's strands for the derived spacing (count)",
       .value = &p.max_root_strands,
       .min = 10,
       .max = 100000,
       .logarithmic = true},
      {.key = "min_particles",
       .help = "fewest particles in a tip cloud (count, >= 3)",
       .value = &p.min_particles,
       .min = 3,
       .max = 50},
      {.key = "new_strand_sparsity",
       .help = "clouds sparser than this (relative to s) get new strands (>= 1)",
       .value = &p.new_strand_sparsity,
       .min = 1,
       .max = 4},
      {.key = "wall_margin",
       .help = "gap between the confining disc and the node radius (relative to the cloud length)",
       .value = &p.wall_margin,
       .min = 0,
       .max = 2},
      {.key = "wall_offset",
       .help = "soft wall: particles are repelled by mirror images this far outside the disc (relative to the "
               "cloud length)",
       .value = &p.wall_offset,
       .min = 0,
       .max = 2},
      {.key = "max_steps",
       .help = "relaxation: largest number of steps per node (count)",
       .value = &p.max_steps,
       .min = 0,
       .max = 400},
      {.key = "move_tolerance",
       .help = "relaxation stops below this largest move (relative to the cloud length)",
       .value = &p.move_tolerance,
       .min = 0.001,
       .max = 0.5,
       .logarithmic = true},
      {.key = "max_velocity",
       .help = "largest move per step (relative to the cloud length)",
       .value = &p.max_velocity,
       .min = 0.01,
       .max = 1},
      {.key = "damping",
       .help = "fraction of the previous step's velocity kept, [0, 1)",
       .value = &p.damping,
       .min = 0,
       .max = 0.95},
      {.key = "step_size",
       .help = "move per step per unit of repulsion (relative to the cloud length)",
       .value = &p.step_size,
       .min = 0.01,
       .max = 1},
      {.key = "repulsion_radius",
       .help = "particles repel within this distance (relative to the cloud length)",
       .value = &p.repulsion_radius,
       .min = 1,
       .max = 5},
      {.key = "rebuild_every",
       .help = "neighbour lists rebuilt every k steps (count)",
       .value = &p.rebuild_every,
       .min = 1,
       .max = 20},
      {.key = "fork_gap",
       .help = "empty band between the two child bundles at a fork (relative to the cloud length)",
       .value = &p.fork_gap,
       .min = 0,
       .max = 3},
      {.key = "max_total_particles",
       .help = "upper bound on the total particle count (count)",
       .value = &p.max_total_particles,
       .min = 1000,
       .max = 5e8,
       .logarithmic = true},
      {.key = "seed", .help = "random seed (tip patterns, new strands)", .value = &p.seed, .min = 0, .max = 1000},
  };
}

std::vector<ParamField> strand_fields(StrandParams& p) {
  return {
      {.key = "alpha",
       .help = "Catmull-Rom exponent: 0 uniform, 0.5 centripetal, 1 chordal",
       .value = &p.alpha,
       .min = 0,
       .max = 1},
  };
}

std::vector<ParamField> contour_fields(ContourParams& p) {
  return {
      {.key = "ring_edge",
       .help = "target loop edge length, slices matched (relative to the neighbour distance; 0 = every boundary strand)",
       .value = &p.ring_edge,
       .min = 0,
       .max = 20},
      {.key = "min_ring_vertices",
       .help = "fewest vertices a loop keeps with ring_edge (count)",
       .value = &p.min_ring_vertices,
       .min = 3,
       .max = 32},
      {.key = "resolution",
       .help = "scales ring resolution and slice spacing together (with ring_edge)",
       .value = &p.resolution,
       .min = 0.1,
       .max = 4},
      {.key = "slice_step",
       .help = "distance between slices (relative to the local radius)",
       .value = &p.slice_step,
       .min = 0.05,
       .max = 2},
      {.key = "max_corner_cut",
       .help = "at a bend, strips pass at most this far from the node, else it gets a loop (relative to its radius)",
       .value = &p.max_corner_cut,
       .min = 0.01,
       .max = 2},
      {.key = "min_slice_step",
       .help = "lower bound on the slice step (relative to the neighbour distance)",
       .value = &p.min_slice_step,
       .min = 0,
       .max = 5},
      {.key = "split_gap",
       .help = "bundles split where they are this far apart (relative to the neighbour distance)",
       .value = &p.split_gap,
       .min = 0.1,
       .max = 5},
      {.key = "thin_gap_radii",
       .help = "at forks of twigs thinner than half the neighbour distance, the split gap is in this many twig radii "
               "instead (0 = always the neighbour distance)",
       .value = &p.thin_gap_radii,
       .min = 0,
       .max = 5},
      {.key = "fork_transition",
       .help =
           "above a fork, a bundle reaches its own round section within this distance (relative to the fork radius)",
       .value = &p.fork_transition,
       .min = 0.1,
       .max = 5},
      {.key = "min_fused_length",
       .help = "unseparated bundles are forced apart no nearer the fork than this (relative to the fork radius)",
       .value = &p.min_fused_length,
       .min = 0,
       .max = 10},
      {.key = "split_nested_laterals",
       .help = "a lateral inside a fused section (whorls) splits off as soon as it is apart from the rest",
       .value = &p.split_nested_laterals,
       .min = 0,
       .max = 1},
      {.key = "split_bisection_steps",
       .help = "bisection steps refining a split (count)",
       .value = &p.split_bisection_steps,
       .min = 0,
       .max = 30},
      {.key = "concave_turn_degrees",
       .help = "angular walk: sharper concave turns drop the point (degrees; 0 = hull)",
       .value = &p.concave_turn_degrees,
       .min = 0,
       .max = 90},
      {.key = "fallback_max_edge",
       .help = "concave fallback for non-star-shaped slices: outline edges longer than this x the "
               "nearest-neighbour distance are carved (0 = convex hull)",
       .value = &p.fallback_max_edge,
       .min = 0,
       .max = 10},
  };
}

std::vector<ParamField> mesh_fields(MeshParams& p) {
  return {
      {.key = "tip_dome",
       .help = "height of the tip caps (relative to the tip loop's radius; 0 = flat)",
       .value = &p.tip_dome,
       .min = 0,
       .max = 2},
      {.key = "uv_repeat_u",
       .help = "texture repeats around the branch",
       .value = &p.uv_repeat_u,
       .min = 0.25,
       .max = 8},
      {.key = "uvs", .help = "compute per-corner UVs", .value = &p.uvs, .min = 0, .max = 1},
      {.key = "normals", .help = "compute smooth vertex normals", .value = &p.normals, .min = 0, .max = 1},
      {.key = "merge_stacked_junctions",
       .help = "mesh junctions a single loop apart as one junction with three or more branches",
       .value = &p.merge_stacked_junctions,
       .min = 0,
       .max = 1},
      {.key = "fold_repair_rounds",
       .help = "rounds of edge flips untangling self-intersections near junctions and caps (0 = off)",
       .value = &p.fold_repair_rounds,
       .min = 0,
       .max = 16},
      {.key = "fold_repair_max_move",
       .help = "largest vertex move of the fold repair, relative to the local radius (0 = flips only)",
       .value = &p.fold_repair_max_move,
       .min = 0,
       .max = 1},
      {.key = "count_pairs_up_to",
       .help = "largest mesh (triangles) whose self-intersecting pairs are counted over the whole mesh for the "
               "variants, the fork retry and the outer surface; larger meshes only near the junctions",
       .value = SizeRef{&p.count_pairs_up_to},
       .min = 1000,
       .max = 1e9,
       .logarithmic = true},
      {.key = "fold_repair_variants",
       .help = "where pairs are left (meshes up to count_pairs_up_to triangles), try two more orders of the repair's "
               "moves",
       .value = &p.fold_repair_variants,
       .min = 0,
       .max = 1},
      {.key = "fork_retry",
       .help = "where self-intersecting pairs or thick nodes outside are left (meshes up to count_pairs_up_to "
               "triangles), re-slice the forks around them with other contour settings and keep each crotch's best (up "
               "to 10 "
               "more runs)",
       .value = &p.fork_retry,
       .min = 0,
       .max = 1},
      {.key = "outer_surface",
       .help = "where self-intersecting pairs or thick nodes outside are still left (meshes up to "
               "count_pairs_up_to triangles), keep the mesh's outer surface (CGAL autorefinement; spheres joined "
               "around the nodes) if "
               "it checks better",
       .value = &p.outer_surface,
       .min = 0,
       .max = 1},
      {.key = "cover_near_misses",
       .help = "push the surface over thick nodes just outside it (within their radius), where no crossing, turned "
               "triangle or lost node results",
       .value = &p.cover_near_misses,
       .min = 0,
       .max = 1},
  };
}

}  // namespace

namespace {

std::vector<ParamField> typed_fields(PipelineParams& params, Stage stage) {
  switch (stage) {
    case Stage::skeleton:
      return skeleton_fields(params.skeleton);
    case Stage::particles:
      return particle_fields(params.particles);
    case Stage::strands:
      return strand_fields(params.strands);
    case Stage::contours:
      return contour_fields(params.contours);
    case Stage::meshing:
      return mesh_fields(params.meshing);
  }
  return {};
}

nlohmann::json config_value(const PipelineParams& params, Stage stage, const std::string& key) {
  const auto j = nlohmann::json::parse(params_to_json(params));
  const auto& section = j.at(stage_name(stage));
  return section.contains(key) ? section.at(key) : nlohmann::json();
}

double config_number(const ConfigRef& r, const std::string& key) {
  const auto v = config_value(*r.params, r.stage, key);
  if (v.is_boolean()) return v.get<bool>() ? 1.0 : 0.0;
  if (v.is_number()) return v.get<double>();
  return 0.0;
}

void set_config_number(const ConfigRef& r, const std::string& key, double v) {
  const auto old = config_value(*r.params, r.stage, key);
  nlohmann::json value;
  if (old.is_boolean()) {
    value = v != 0.0;
  } else if (old.is_number_unsigned()) {
    value = clamp_to<std::uint64_t>(v);
  } else if (old.is_number_integer()) {
    value = clamp_to<std::int64_t>(v);
  } else if (old.is_number()) {
    value = v;
  } else {
    return;  // text values are not edited as numbers
  }
  nlohmann::json doc;
  doc[stage_name(r.stage)][key] = value;
  *r.params = parse_params_json(doc.dump(), "viewer", *r.params);
}

}  // namespace

std::vector<ParamField> param_fields(PipelineParams& params, Stage stage) {
  std::vector<ParamField> out = typed_fields(params, stage);
  const auto j = nlohmann::json::parse(params_to_json(params));
  const auto& section = j.at(stage_name(stage));
  for (const auto& [key, value] : section.items()) {
    const bool known = std::any_of(out.begin(), out.end(), [&](const ParamField& f) { return f.key == key; });
    if (known) continue;
    ParamField f;
    f.key = key;
    f.help = "(not yet described in the viewer; see the stage's Params header)";
    f.value = ConfigRef{&params, stage};
    f.min = 0;
    f.max = value.is_number() ? std::max(1.0, 4.0 * std::fabs(value.get<double>())) : 1.0;
    out.push_back(std::move(f));
  }
  return out;
}

ConfigKind config_kind(const ParamField& f) {
  const auto* r = std::get_if<ConfigRef>(&f.value);
  if (!r) return ConfigKind::number;
  const auto v = config_value(*r->params, r->stage, f.key);
  if (v.is_boolean()) return ConfigKind::boolean;
  if (v.is_number_integer()) return ConfigKind::integer;
  if (v.is_number()) return ConfigKind::number;
  return ConfigKind::text;
}

double field_value(const ParamField& f) {
  return std::visit(
      [&f](auto p) -> double {
        using P = decltype(p);
        if constexpr (std::is_same_v<P, SizeRef>) {
          return static_cast<double>(*p.p);
        } else if constexpr (std::is_same_v<P, ConfigRef>) {
          return config_number(p, f.key);
        } else if constexpr (std::is_same_v<P, bool*>) {
          return *p ? 1.0 : 0.0;
        } else if constexpr (std::is_same_v<P, ThickChildPolicy*>) {
          return static_cast<double>(static_cast<int>(*p));
        } else {
          return static_cast<double>(*p);
        }
      },
      f.value);
}

void set_field_value(const ParamField& f, double v) {
  std::visit(
      [v, &f](auto p) {
        using P = decltype(p);
        if constexpr (std::is_same_v<P, SizeRef>) {
          *p.p = clamp_to<std::size_t>(v);
        } else if constexpr (std::is_same_v<P, ConfigRef>) {
          set_config_number(p, f.key, v);
        } else if constexpr (std::is_same_v<P, bool*>) {
          *p = v != 0.0;
        } else if constexpr (std::is_same_v<P, ThickChildPolicy*>) {
          *p = static_cast<ThickChildPolicy>(std::clamp(static_cast<int>(std::lround(v)), 0, 2));
        } else if constexpr (std::is_same_v<P, double*>) {
          *p = v;
        } else {
          *p = clamp_to<std::remove_pointer_t<P>>(v);
        }
      },
      f.value);
}

std::optional<Stage> first_changed_stage(const PipelineParams& a, const PipelineParams& b) {
  // Compared in the config-file form, so that no field is forgotten, whatever the table
  // knows; fields the config file does not carry are compared through the typed table.
  const auto ja = nlohmann::json::parse(params_to_json(a));
  const auto jb = nlohmann::json::parse(params_to_json(b));
  PipelineParams ca = a, cb = b;
  for (Stage s : kStages) {
    if (ja.at(stage_name(s)) != jb.at(stage_name(s))) return s;
    const auto fa = typed_fields(ca, s);
    const auto fb = typed_fields(cb, s);
    for (std::size_t i = 0; i < fa.size(); ++i) {
      if (field_value(fa[i]) != field_value(fb[i])) return s;
    }
  }
  return std::nullopt;
}

}  // namespace sm::viewer
