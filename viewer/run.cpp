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

#include <nlohmann/json.hpp>

#include "contours/dump.h"
#include "core/errors.h"
#include "core/file_io.h"
#include "core/input_limits.h"
#include "meshio/mesh_io.h"
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
    // Stitched and repaired as the run was, but for the fork retry: it slices contours again,
    // from particles a dump may not have.
    RepairParams repair = params.repair;
    repair.fork_retry = false;
    const Skeleton input = run.raw ? input_skeleton(*run.raw, params.skeleton) : Skeleton{};
    const RepairInputs inputs{s, run.result.particles, run.result.strands, params.contours, params.meshing,
                              run.raw ? &input : nullptr};
    run.result.repair = repair_mesh(stitch_mesh(s, run.result.contours, params.meshing), run.result.contours,
                                    run.result.mesh, inputs, repair);
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
