#pragma once
/// The whole pipeline: skeleton → particles → strands → contours → meshing → repair. The CLI
/// and the viewer only call this (and the stage entry points); they never reach into a stage.

#include <filesystem>
#include <string>
#include <string_view>

#include "contours/contours.h"
#include "core/progress.h"
#include "core/report.h"
#include "meshing/meshing.h"
#include "meshio/export.h"
#include "particles/particles.h"
#include "repair/repair.h"
#include "skeleton/build.h"
#include "strands/strands.h"

namespace sm {

/// Every stage's parameters. Defaults are the documented defaults of each Params struct.
struct PipelineParams {
  SkeletonParams skeleton;
  ParticleParams particles;
  StrandParams strands;
  ContourParams contours;
  MeshParams meshing;
  RepairParams repair;
  /// How the mesh is written (config section "export"; meshio/param_table.cpp). Not a stage:
  /// the pipeline only carries it from the config file to the command that writes.
  ExportParams output;
};

/// Calls `f(stage_params)` on each stage's Params of `p` in pipeline order (skeleton,
/// particles, strands, contours, meshing, repair); with param_table_of, the generic walk over
/// every parameter (config files, the viewer, `strandmesh params`).
template <class PP, class F>
  requires std::is_same_v<std::remove_const_t<PP>, PipelineParams>
void for_each_stage_params(PP& p, F&& f) {
  f(p.skeleton);
  f(p.particles);
  f(p.strands);
  f(p.contours);
  f(p.meshing);
  f(p.repair);
}

/// for_each_stage_params, then the writer's options (PipelineParams::output, section
/// "export"): every section of a config file, as the reader, the writer, validation and the
/// reference walk them.
template <class PP, class F>
  requires std::is_same_v<std::remove_const_t<PP>, PipelineParams>
void for_each_config_section(PP& p, F&& f) {
  for_each_stage_params(p, f);
  f(p.output);
}

/// The stages, in order; `rerun_pipeline` restarts from one of them.
enum class Stage { skeleton = 0, particles, strands, contours, meshing };
const char* stage_name(Stage s);

/// Parses a config file: {"skeleton": {...}, "particles": {...}, "strands": {...},
/// "contours": {...}, "meshing": {...}, "repair": {...}, "export": {...}}, every section and
/// key optional, values overriding
/// the defaults in `base`. An unknown section or key, or a value of the wrong type, throws
/// InvalidInputError naming the file, the key and the accepted keys.
PipelineParams parse_params_json(std::string_view text, const std::string& name, const PipelineParams& base = {});
PipelineParams load_params(const std::filesystem::path& path, const PipelineParams& base = {});
/// All parameters as a config file (every key, current values); parse_params_json reads it back.
std::string params_to_json(const PipelineParams& params);
/// The parameter reference from the stage tables: every key with its default, accepted values,
/// unit and meaning; as Markdown tables per section (`strandmesh params --markdown`, the
/// reference in docs/defaults.md) or as plain text (`strandmesh params`).
std::string params_reference(bool markdown);

struct PipelineResult {
  SkeletonResult skeleton;
  ParticleField particles;
  StrandSet strands;
  ContourSet contours;
  /// The repaired mesh (the meshing stage stitches it, the repair stage repairs and finishes it).
  MeshResult mesh;
  /// The repair stage's figures, every step's.
  RepairStats repair;
  /// Seconds per stage: "skeleton", "particles", "strands", "contours", "meshing", "repair".
  Timings timings;
  /// Warnings of every stage, in stage order.
  [[nodiscard]] Warnings warnings() const;
};

/// Frees the per-particle and per-vertex arrays of the intermediate stages (strand points and
/// tangents, contour vertices) once a run is finished, keeping the mesh, every stage's
/// figures and warnings, and what `stats_to_json` reads. A command that only exports the mesh
/// calls it first: the exporter then reuses that memory instead of touching new pages (on
/// the large grow preset, 3.4 M triangles, about 170 MB). rerun_pipeline and dump_stages
/// need the arrays: neither may be called afterwards.
void release_intermediates(PipelineResult& r);

/// Runs every stage on `raw`. Throws InvalidInputError for malformed skeletons or parameters.
/// `progress` receives (stage name, fraction of that stage).
PipelineResult run_pipeline(const RawSkeleton& raw, const PipelineParams& params, const ProgressFn& progress = {});

/// Re-runs the stages from `from` on with new parameters, keeping the earlier stages of
/// `result` (which must come from the same raw skeleton). Used by the viewer.
void rerun_pipeline(PipelineResult& result, const RawSkeleton& raw, const PipelineParams& params, Stage from,
                    const ProgressFn& progress = {});

/// Writes the stage results for the viewer and for debugging into `dir` (created if needed):
/// skeleton.json (the sanitized skeleton), particles.json, strands.json, contours.json and
/// stats.json. Each file is written atomically.
void dump_stages(const PipelineResult& result, const std::filesystem::path& dir);

/// The run's figures as JSON: nodes, strands, particles (sum over nodes), slices, vertices,
/// triangles, warnings, and seconds per stage.
std::string stats_to_json(const PipelineResult& result, double export_seconds = 0, double total_seconds = 0);

}  // namespace sm
