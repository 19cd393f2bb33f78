// Loading what the viewer shows: pipeline runs, stage dumps and mesh files.
//
// A stage dump holds what `dump_stages` (pipeline/pipeline.cpp) writes. The viewer reads it
// back so that a run made elsewhere (a CI machine, a colleague's config) can be inspected
// without re-running the expensive stages: the particles are taken as they were dumped, and
// only the cheap, deterministic steps that the dump does not store (strand curves, loop
// frames) are recomputed.

#include "viewer/run.h"

#include <algorithm>
#include <system_error>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/file_io.h"
#include "core/input_limits.h"
#include "meshing/mesh_io.h"
#include "particles/dump.h"
#include "skeleton/io.h"

namespace sm::viewer {

namespace {

std::size_t idx(Stage s) {
  return static_cast<std::size_t>(s);
}

bool is_mesh_extension(const std::string& ext) {
  return ext == "glb" || ext == "gltf" || ext == "obj" || ext == "ply";
}

const nlohmann::json& require(const nlohmann::json& j, const char* key, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw InvalidInputError(where + ": missing key \"" + key + "\"");
  return j.at(key);
}

glm::dvec3 vec3_of(const nlohmann::json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number()) {
    throw InvalidInputError(where + ": expected [x, y, z]");
  }
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

// The slice frame the contours stage uses for a slice at parameter t on the edge of node n:
// the parent's frame transported to the interpolated tangent (contours.cpp, edge_geometry).
Frame slice_frame(const Skeleton& s, NodeId n, double t) {
  const NodeId p = s.parent[n.idx()];
  if (!p.valid()) return s.frame[n.idx()];
  const Frame& fp = s.frame[p.idx()];
  const Frame& fn = s.frame[n.idx()];
  const dvec3 tangent = normalize_or(glm::mix(fp.tangent, fn.tangent, t), fn.tangent);
  return transport_frame(fp, tangent);
}

std::filesystem::path find_mesh_in(const std::filesystem::path& dir) {
  std::vector<std::filesystem::path> found;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    if (e.is_regular_file() && is_mesh_extension(extension_of(e.path()))) found.push_back(e.path());
  }
  std::sort(found.begin(), found.end());
  return found.empty() ? std::filesystem::path{} : found.front();
}

}  // namespace

InputKind classify_input(const std::filesystem::path& path) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw IoError(path.string() + ": no such file or directory");
  if (std::filesystem::is_directory(path, ec)) return InputKind::stage_dump;
  if (is_mesh_extension(extension_of(path))) return InputKind::mesh;
  return InputKind::skeleton;
}

StageView view_of(const RunData& run) {
  StageView v;
  const PipelineResult& r = run.result;
  if (run.has_stage(Stage::skeleton)) v.skeleton = &r.skeleton.skeleton;
  if (run.has_stage(Stage::particles) && v.skeleton) v.particles = &r.particles;
  if (run.has_stage(Stage::strands) && v.particles) v.strands = &r.strands;
  if (run.has_stage(Stage::contours)) v.contours = &r.contours;
  if (run.has_stage(Stage::meshing)) v.mesh = &r.mesh.mesh;
  return v;
}

RunData run_skeleton_file(const std::filesystem::path& path, const PipelineParams& params, const ProgressFn& progress) {
  RunData run;
  run.kind = InputKind::skeleton;
  run.path = path;
  if (progress) progress("reading", 0);
  run.raw = std::make_shared<const RawSkeleton>(read_skeleton(path));
  run.result = run_pipeline(*run.raw, params, progress);
  run.has.fill(true);
  run.note = "pipeline run on " + path.filename().string();
  return run;
}

ContourSet contours_from_json(const std::string& text, const Skeleton& skeleton, const std::string& name,
                              const ParticleField* field) {
  check_json_nesting(text, name);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InvalidInputError(name + ": not JSON: " + e.what());
  }
  ContourSet c;
  c.loop_begin.push_back(0);
  const auto& loops = require(j, "loops", name);
  if (!loops.is_array()) throw InvalidInputError(name + ": \"loops\" is not an array");
  try {
    for (std::size_t l = 0; l < loops.size(); ++l) {
      const std::string where = name + ": loops[" + std::to_string(l) + "]";
      const auto& L = loops[l];
      const std::int64_t node = require(L, "node", where).get<std::int64_t>();
      if (node < 0 || static_cast<std::size_t>(node) >= skeleton.size()) {
        throw InvalidInputError(where + ": node " + std::to_string(node) + " is not a node of skeleton.json");
      }
      const double t = require(L, "t", where).get<double>();
      const std::string kind = require(L, "kind", where).get<std::string>();
      LoopKind k = LoopKind::plain;
      if (kind == "plain")
        k = LoopKind::plain;
      else if (kind == "fused")
        k = LoopKind::fused;
      else if (kind == "split")
        k = LoopKind::split;
      else if (kind == "tip")
        k = LoopKind::tip;
      else
        throw InvalidInputError(where + ": unknown kind \"" + kind + "\" (plain, fused, split, tip)");
      const auto& strands = require(L, "strands", where);
      const auto& points = require(L, "points", where);
      if (!strands.is_array() || !points.is_array() || strands.size() != points.size()) {
        throw InvalidInputError(where + ": \"strands\" and \"points\" must be arrays of equal length");
      }
      for (std::size_t v = 0; v < points.size(); ++v) {
        c.point.push_back(vec3_of(points[v], where + ".points[" + std::to_string(v) + "]"));
        const std::int64_t s = strands[v].get<std::int64_t>();
        c.strand.push_back(s < 0 ? StrandId{} : StrandId(static_cast<std::uint32_t>(s)));
      }
      c.loop_begin.push_back(static_cast<std::uint32_t>(c.point.size()));
      const NodeId n(static_cast<std::uint32_t>(node));
      c.loop_node.push_back(n);
      c.loop_t.push_back(t);
      c.loop_distance.push_back(L.value("distance", 0.0));
      c.loop_radius.push_back(L.value("radius", skeleton.radius[n.idx()]));
      c.loop_center.push_back(L.contains("center") ? vec3_of(L["center"], where + ".center")
                                                   : skeleton.position[n.idx()]);
      c.loop_frame.push_back(slice_frame(skeleton, n, t));
      c.loop_kind.push_back(k);
      if (k == LoopKind::fused) ++c.stats.fused_loops;
    }
    const std::uint32_t loop_count = static_cast<std::uint32_t>(c.loop_kind.size());
    auto loop_index = [&](const nlohmann::json& v, const std::string& where) {
      const std::int64_t i = v.get<std::int64_t>();
      if (i < 0 || i >= loop_count) throw InvalidInputError(where + ": loop " + std::to_string(i) + " does not exist");
      return static_cast<std::uint32_t>(i);
    };
    if (j.contains("tubes")) {
      for (std::size_t t = 0; t < j["tubes"].size(); ++t) {
        const std::string where = name + ": tubes[" + std::to_string(t) + "]";
        const auto& T = j["tubes"][t];
        Tube tube;
        for (const auto& l : require(T, "loops", where)) tube.loops.push_back(loop_index(l, where));
        tube.branch = NodeId(static_cast<std::uint32_t>(T.value("branch", 0)));
        const std::int64_t sj = T.value("start_junction", std::int64_t(-1));
        const std::int64_t ej = T.value("end_junction", std::int64_t(-1));
        tube.start_junction = sj < 0 ? UINT32_MAX : static_cast<std::uint32_t>(sj);
        tube.end_junction = ej < 0 ? UINT32_MAX : static_cast<std::uint32_t>(ej);
        c.tubes.push_back(std::move(tube));
      }
    }
    if (j.contains("junctions")) {
      for (std::size_t k = 0; k < j["junctions"].size(); ++k) {
        const std::string where = name + ": junctions[" + std::to_string(k) + "]";
        const auto& J = j["junctions"][k];
        Junction jn;
        jn.fork = NodeId(static_cast<std::uint32_t>(require(J, "fork", where).get<std::int64_t>()));
        jn.lower = loop_index(require(J, "lower", where), where);
        const auto& up = require(J, "upper", where);
        if (!up.is_array() || up.size() != 2) throw InvalidInputError(where + ": \"upper\" must hold two loops");
        jn.upper = {loop_index(up[0], where), loop_index(up[1], where)};
        jn.split_distance = J.value("split_distance", 0.0);
        jn.forced = J.value("forced", false);
        if (jn.forced) ++c.stats.forced_splits;
        c.junctions.push_back(jn);
      }
    }
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInputError(name + ": wrong value type: " + e.what());
  }
  // The tube indices of each junction follow from the tubes' start and end junctions.
  for (std::uint32_t t = 0; t < c.tubes.size(); ++t) {
    const Tube& tube = c.tubes[t];
    if (tube.end_junction < c.junctions.size()) c.junctions[tube.end_junction].lower_tube = t;
    if (tube.start_junction < c.junctions.size()) {
      Junction& jn = c.junctions[tube.start_junction];
      if (!tube.loops.empty() && tube.loops.front() == jn.upper[1])
        jn.upper_tubes[1] = t;
      else
        jn.upper_tubes[0] = t;
    }
  }
  if (field && field->node_count() == skeleton.size()) {
    // Which bundle each lower-loop strand belongs to: particle order at the fork is
    // [main child's strands | lateral's | new at the fork] (particles/particles.h).
    for (Junction& jn : c.junctions) {
      const NodeId fork = jn.fork;
      if (!fork.valid() || fork.idx() >= skeleton.size() || !skeleton.is_fork(fork)) {
        throw InvalidInputError(name + ": junction at node " + std::to_string(fork.value) + ", which is not a fork");
      }
      const std::uint32_t base = field->node_begin[fork.idx()];
      const std::uint32_t n_main = field->count(skeleton.children[fork.idx()][0]);
      const std::uint32_t n_both = std::min(field->new_begin[fork.idx()], field->count(fork));
      std::unordered_map<std::uint32_t, std::uint8_t> side;
      for (std::uint32_t q = 0; q < n_both; ++q) side.emplace(field->strand[base + q].value, q < n_main ? 0 : 1);
      jn.lower_side.assign(c.loop_size(jn.lower), 2);
      for (std::uint32_t k = 0; k < jn.lower_side.size(); ++k) {
        const auto it = side.find(c.strand[c.loop_begin[jn.lower] + k].value);
        if (it != side.end()) jn.lower_side[k] = it->second;
      }
    }
  }
  c.stats.loops = c.loop_count();
  c.stats.loop_vertices = c.point.size();
  return c;
}

RunData load_stage_dump(const std::filesystem::path& dir, const PipelineParams& params,
                        const std::filesystem::path& mesh_file, const ProgressFn& progress) {
  auto report = [&](std::string_view phase, double f) {
    if (progress) progress(phase, f);
  };
  RunData run;
  run.kind = InputKind::stage_dump;
  run.path = dir;
  std::error_code ec;
  const auto skel_path = dir / "skeleton.json";
  if (!std::filesystem::exists(skel_path, ec)) {
    throw InvalidInputError(dir.string() +
                            ": not a stage dump (no skeleton.json; write one with "
                            "`strandmesh mesh SKELETON -o OUT --dump-stages DIR`)");
  }
  report("skeleton", 0);
  run.raw = std::make_shared<const RawSkeleton>(parse_skeleton_json(read_file(skel_path), skel_path.string()));
  run.result.skeleton = build_skeleton(*run.raw, params.skeleton);
  run.has[idx(Stage::skeleton)] = true;
  const Skeleton& s = run.result.skeleton.skeleton;
  std::string note = "stage dump " + dir.string() + ": skeleton";

  const auto particles_path = dir / "particles.json";
  if (std::filesystem::exists(particles_path, ec)) {
    report("particles", 0);
    run.result.particles = particles_from_json(read_file(particles_path));
    if (run.result.particles.node_count() != s.size()) {
      throw InvalidInputError(particles_path.string() + ": " + std::to_string(run.result.particles.node_count()) +
                              " nodes, but skeleton.json has " + std::to_string(s.size()) +
                              " after sanitizing; the files are not from the same run (or the skeleton parameters "
                              "differ from the run's; pass its --config)");
    }
    run.has[idx(Stage::particles)] = true;
    note += ", particles";
    report("strands", 0);
    run.result.strands = build_strands(s, run.result.particles, params.strands);
    run.has[idx(Stage::strands)] = true;
    note += ", strands (rebuilt from the particles)";
  }
  const auto contours_path = dir / "contours.json";
  if (std::filesystem::exists(contours_path, ec)) {
    report("contours", 0);
    run.result.contours = contours_from_json(read_file(contours_path), s, contours_path.string(),
                                             run.has_stage(Stage::particles) ? &run.result.particles : nullptr);
    run.has[idx(Stage::contours)] = true;
    note += ", contours";
  }
  std::filesystem::path mesh_path = mesh_file.empty() ? find_mesh_in(dir) : mesh_file;
  if (!mesh_path.empty()) {
    report("mesh", 0);
    run.result.mesh.mesh = read_mesh(mesh_path, {.up_axis = s.up_axis});
    run.result.mesh.stats.vertices = run.result.mesh.mesh.vertex_count();
    run.result.mesh.stats.triangles = run.result.mesh.mesh.triangle_count();
    run.has[idx(Stage::meshing)] = true;
    note += ", mesh from " + mesh_path.filename().string();
  } else if (run.has_stage(Stage::contours)) {
    report("meshing", 0);
    run.result.mesh = build_mesh(s, run.result.contours, params.meshing);
    run.has[idx(Stage::meshing)] = true;
    note += ", mesh (rebuilt from the contours)";
  }
  const auto stats_path = dir / "stats.json";
  if (std::filesystem::exists(stats_path, ec)) {
    // The dumped run's timings, so the status panel shows what the run cost where it ran.
    try {
      const std::string text = read_file(stats_path);
      check_json_nesting(text, stats_path.string());
      const auto j = nlohmann::json::parse(text);
      if (j.contains("seconds") && j["seconds"].is_object()) {
        for (const char* st : {"skeleton", "particles", "strands", "contours", "meshing"}) {
          if (j["seconds"].contains(st) && j["seconds"][st].is_number()) {
            run.result.timings.add(st, j["seconds"][st].get<double>());
          }
        }
      }
    } catch (const nlohmann::json::exception&) {
      note += " (stats.json unreadable, ignored)";
    }
  }
  run.note = note;
  return run;
}

RunData load_mesh_file(const std::filesystem::path& path) {
  RunData run;
  run.kind = InputKind::mesh;
  run.path = path;
  run.result.mesh.mesh = read_mesh(path);
  run.result.mesh.stats.vertices = run.result.mesh.mesh.vertex_count();
  run.result.mesh.stats.triangles = run.result.mesh.mesh.triangle_count();
  run.has[idx(Stage::meshing)] = true;
  run.note = "mesh file " + path.filename().string() + " (no stages to re-run)";
  return run;
}

RunData load_input(const std::filesystem::path& path, const PipelineParams& params,
                   const std::filesystem::path& mesh_file, const ProgressFn& progress) {
  switch (classify_input(path)) {
    case InputKind::stage_dump:
      return load_stage_dump(path, params, mesh_file, progress);
    case InputKind::mesh:
      return load_mesh_file(path);
    case InputKind::skeleton:
      break;
  }
  return run_skeleton_file(path, params, progress);
}

void rerun(RunData& run, const PipelineParams& params, Stage from, const ProgressFn& progress) {
  SM_CHECK(run.can_rerun(), "rerun: the run has no raw skeleton");
  // Every stage before `from` must be present; otherwise start earlier.
  Stage start = from;
  for (int s = 0; s < static_cast<int>(from); ++s) {
    if (!run.has[static_cast<std::size_t>(s)]) {
      start = static_cast<Stage>(s);
      break;
    }
  }
  run.check.reset();
  rerun_pipeline(run.result, *run.raw, params, start, progress);
  run.has.fill(true);
  if (run.kind == InputKind::stage_dump)
    run.note = "stage dump " + run.path.string() + ", re-run from " + stage_name(start);
}

MeshCheckReport run_checks(const RunData& run, bool self_intersections) {
  SM_CHECK(run.has_stage(Stage::meshing), "run_checks: no mesh");
  MeshCheckParams p;
  p.self_intersections = self_intersections;
  p.max_examples = kMaxProblemsShown;
  if (run.has_stage(Stage::skeleton)) p.skeleton = &run.result.skeleton.skeleton;
  return check_mesh(run.result.mesh.mesh, p);
}

}  // namespace sm::viewer
