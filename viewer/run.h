#pragma once
/// What the viewer shows and where it comes from: a pipeline run on a skeleton file, a stage
/// dump written by `strandmesh mesh --dump-stages DIR`, or a mesh file alone. Loading and
/// re-running are plain functions (they run on the viewer's worker thread, viewer/job.h).

#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "core/progress.h"
#include "meshcheck/checks.h"
#include "pipeline/pipeline.h"
#include "viewer/scene.h"

namespace sm::viewer {

/// What kind of input a path is.
enum class InputKind {
  skeleton,    ///< a skeleton file (.json, .swc): the pipeline runs on it
  stage_dump,  ///< a directory written by --dump-stages (skeleton.json, particles.json, ...)
  mesh,        ///< a mesh file (.glb, .gltf, .obj, .ply): shown alone
};

/// Classifies `path`: a directory is a stage dump, a mesh extension a mesh, anything else a
/// skeleton. Throws IoError when the path does not exist.
InputKind classify_input(const std::filesystem::path& path);

/// One run's stage results. `has[stage]` tells which stages are present (a mesh file has only
/// the mesh; a dump without contours.json has no contours).
struct RunData {
  InputKind kind = InputKind::skeleton;
  std::filesystem::path path;              ///< the input
  std::shared_ptr<const RawSkeleton> raw;  ///< the raw skeleton re-runs start from (null for a mesh file)
  PipelineResult result;                   ///< the stages (only those in `has` are meaningful)
  std::array<bool, 5> has{};               ///< per Stage: present
  std::optional<MeshCheckReport> check;    ///< mesh checks, once they ran
  std::string note;                        ///< how the data was obtained (shown in the status panel)

  [[nodiscard]] bool has_stage(Stage s) const { return has[static_cast<std::size_t>(s)]; }
  /// Whether stages can be re-run (there is a raw skeleton).
  [[nodiscard]] bool can_rerun() const { return raw != nullptr; }
};

/// The stage results of a run as a StageView (null pointers for absent stages).
StageView view_of(const RunData& run);

/// Reads a skeleton file and runs the whole pipeline.
RunData run_skeleton_file(const std::filesystem::path& path, const PipelineParams& params,
                          const ProgressFn& progress = {});

/// Loads a stage dump directory (the files `dump_stages` writes, pipeline/pipeline.h):
///  - skeleton.json: the sanitized skeleton, rebuilt with build_skeleton (it round-trips);
///  - particles.json: the particle field (particles/dump.h);
///  - strands: rebuilt from the particles with `params.strands` (a pure function of them);
///  - contours.json: loops, tubes and junctions (contours/dump.h); the loop frames (not in
///    the file) are recomputed from the skeleton the way the contours stage derives them;
///  - the mesh: `mesh_file` when given, else the first .glb/.gltf/.obj/.ply file in the
///    directory, else build_mesh on the loaded contours with `params.meshing`.
/// Files that are missing leave their stage (and the later ones) absent; RunData::note says
/// which. Throws InvalidInputError when skeleton.json is missing or a file is malformed or
/// the files do not belong together (node counts differ).
RunData load_stage_dump(const std::filesystem::path& dir, const PipelineParams& params,
                        const std::filesystem::path& mesh_file = {}, const ProgressFn& progress = {});

/// Reads a mesh file (meshio/mesh_io.h) into a run with only the mesh stage present.
RunData load_mesh_file(const std::filesystem::path& path);

/// Loads any input by its kind (`mesh_file` only applies to stage dumps).
RunData load_input(const std::filesystem::path& path, const PipelineParams& params,
                   const std::filesystem::path& mesh_file = {}, const ProgressFn& progress = {});

/// Re-runs the stages from `from` on with `params` (run.can_rerun() must hold). On success
/// every stage is present and the checks are cleared; on an exception `run` is left partly
/// updated, so callers work on a copy (the viewer keeps showing the previous run).
void rerun(RunData& run, const PipelineParams& params, Stage from, const ProgressFn& progress = {});

/// Offenders of each kind the viewer's checks list for the problems layer (count).
inline constexpr std::size_t kMaxProblemsShown = 100'000;

/// Runs the mesh checks (with the skeleton for fidelity when there is one), listing up to
/// kMaxProblemsShown offenders of each kind (the problems layer shows them).
/// Precondition: the mesh stage is present.
MeshCheckReport run_checks(const RunData& run, bool self_intersections = true);

}  // namespace sm::viewer
