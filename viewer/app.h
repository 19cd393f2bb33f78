#pragma once
/// The viewer's state and behaviour without a window: what is loaded, which layers show, the
/// camera, the selection, the edited parameters and the background job. The GLFW window
/// (viewer/window.h) feeds it input in pixels and asks it to draw through a Renderer; the
/// ImGui panels (viewer/panels.h) read and change it. Tests drive it with the mock backend.
///
/// Threading: every member function is called on the render thread. Loading, re-running and
/// mesh checks run on the job's thread (viewer/job.h) on copies; update() takes their results.

#include <array>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "viewer/backend.h"
#include "viewer/camera.h"
#include "viewer/job.h"
#include "viewer/node_view.h"
#include "viewer/run.h"
#include "viewer/scene.h"

namespace sm::viewer {

/// What to open and how (from the command line).
struct ViewerOptions {
  std::filesystem::path input;        ///< skeleton file, stage dump directory or mesh file
  std::filesystem::path config;       ///< parameter file (JSON), or empty for the defaults
  std::optional<std::uint64_t> seed;  ///< overrides particles.seed
  std::filesystem::path mesh;         ///< for a stage dump: the mesh file to show with it
  bool checks = true;                 ///< run the mesh checks after every run
  bool self_intersections = true;     ///< include the (slowest) self-intersection check
};

/// Which layers show and how things are coloured.
struct ViewState {
  std::array<bool, kLayerCount> visible{};  ///< per Layer
  StrandColoring coloring = StrandColoring::by_strand;
  MeshShading shading = MeshShading::smooth;
  bool legend = true;
};

/// The layers `--layers` names: a comma-separated list of layer names (viewer/scene.h
/// layer_name), plus `uv` (the mesh with the UV checker), `legend` and `all`.
/// Throws UsageError naming an unknown entry and listing the accepted ones.
ViewState parse_layers(const std::string& list);
/// Parses `WxH` (e.g. 1280x800); throws UsageError unless both are in [16, 8192].
std::array<int, 2> parse_size(const std::string& text);
/// The default view for what a run contains: the mesh and the skeleton when there is a mesh,
/// else the deepest stage present.
ViewState default_view(const RunData& run);

class ViewerApp {
 public:
  explicit ViewerApp(ViewerOptions options);

  // --- lifecycle -------------------------------------------------------------------------
  /// Reads the config (errors are shown, defaults used) and starts loading the input.
  void start();
  /// Takes finished jobs' results and starts queued work. Call once per frame.
  void update();
  /// Blocks until no job runs and nothing is queued (screenshots and tests).
  void wait_idle();
  /// True while a job runs or work is queued.
  [[nodiscard]] bool busy() const;
  [[nodiscard]] JobProgress progress() const { return job_.progress(); }
  /// Cancels the running job (its stage stops at its next progress report).
  void cancel();

  // --- runs ------------------------------------------------------------------------------
  /// Re-runs from `from` with the edited parameters (queued while a job runs).
  void request_rerun(Stage from);
  /// Re-runs from the first stage whose edited parameters differ from the applied ones; no-op
  /// when nothing changed. Returns the stage, if any.
  std::optional<Stage> apply_changes();
  /// Runs the mesh checks on the current run.
  void request_checks();
  /// Loads the input again from scratch with the edited parameters.
  void reload();

  [[nodiscard]] const RunData* run() const { return run_.get(); }
  [[nodiscard]] const std::optional<MeshCheckReport>& check() const { return check_; }
  [[nodiscard]] PipelineParams& edited_params() { return edited_; }
  [[nodiscard]] const PipelineParams& applied_params() const { return applied_; }
  [[nodiscard]] const ViewerOptions& options() const { return options_; }
  /// The last error (load, re-run, checks, config); empty when none. Shown in the window.
  [[nodiscard]] const std::string& error() const { return error_; }
  void clear_error() { error_.clear(); }
  /// Shows a message as the current error (the panels' invalid edits).
  void show_error(std::string message) { error_ = std::move(message); }
  /// Seconds the last load or re-run took (wall clock, including reading files).
  [[nodiscard]] double last_run_seconds() const { return last_run_seconds_; }

  // --- view ------------------------------------------------------------------------------
  [[nodiscard]] const ViewState& view() const { return view_; }
  void set_layer_visible(Layer layer, bool on) { view_.visible[static_cast<std::size_t>(layer)] = on; }
  void set_coloring(StrandColoring coloring);
  void set_shading(MeshShading shading) { view_.shading = shading; }
  void set_legend(bool on) { view_.legend = on; }
  /// Replaces the whole view state (e.g. from --layers); keeps it across later runs.
  void set_view(const ViewState& view);

  [[nodiscard]] OrbitCamera& camera() { return camera_; }
  [[nodiscard]] const OrbitCamera& camera() const { return camera_; }
  /// Frames everything (aspect = width / height of the viewport).
  void frame_all(double aspect);
  /// Frames the selected node's subtree; false when nothing is selected.
  bool frame_selection(double aspect);
  /// Applies a --camera spec (frames spec.node's subtree, or a ball around it, when given).
  void apply_camera_spec(const CameraSpec& spec, double aspect);
  /// A camera spec and a node to select once the first run is shown (the window's --camera
  /// and --select); problems are reported through error().
  void set_initial_view(std::optional<CameraSpec> camera, std::optional<std::uint32_t> select);

  /// Selects a node (or clears the selection); the node panel's cloud is recomputed.
  void select(std::optional<NodeId> node);
  [[nodiscard]] std::optional<NodeId> selection() const { return selection_; }
  /// The selected node's cloud, when a node is selected and particles exist.
  [[nodiscard]] const NodeCloud* selected_cloud() const { return cloud_ ? &*cloud_ : nullptr; }

  // --- input (pixels, origin top-left) ----------------------------------------------------
  enum class Drag { rotate, pan };
  void on_drag(Drag kind, double dx, double dy, int width, int height);
  void on_scroll(double steps) { camera_.zoom(steps); }
  /// A click without drag: picks the node under the mouse (or clears the selection).
  void on_click(double x, double y, int width, int height);

  // --- drawing ---------------------------------------------------------------------------
  /// Hands scene changes to `renderer` and draws one frame of width × height pixels.
  void render(Renderer& renderer, int width, int height);
  /// The camera's view and projection for a viewport.
  [[nodiscard]] glm::mat4 view_matrix() const { return camera_.view(); }
  [[nodiscard]] glm::mat4 projection_matrix(int width, int height) const;
  /// Origin and bounds of the current scene (local coordinates).
  [[nodiscard]] const glm::dvec3& scene_origin() const { return origin_; }
  [[nodiscard]] const Bounds& scene_bounds() const { return bounds_; }
  /// Increases each time the scene is rebuilt (a new run or colouring).
  [[nodiscard]] std::uint64_t scene_version() const { return scene_version_; }

 private:
  void start_job(JobOutcome::Kind kind, Job::Work work, const PipelineParams& params);
  void start_rerun(Stage from);
  void on_outcome(JobOutcome outcome);
  void rebuild_scene();
  void rebuild_selection();
  /// Hands one layer's new batches to the renderer on the next frame (into the pending scene
  /// when a whole new scene is waiting).
  void replace_layer(Layer layer, std::vector<Batch> batches);

  ViewerOptions options_;
  PipelineParams edited_, applied_, job_params_;
  std::shared_ptr<const RunData> run_;
  std::optional<MeshCheckReport> check_;
  std::string error_;
  double last_run_seconds_ = 0;

  Job job_;
  std::optional<Stage> queued_rerun_;
  bool queued_checks_ = false;
  bool queued_reload_ = false;

  ViewState view_;
  bool view_fixed_ = false;  // set_view() called: keep the user's layers across runs
  OrbitCamera camera_;
  bool needs_framing_ = true;
  std::optional<CameraSpec> initial_camera_;
  std::optional<std::uint32_t> initial_select_;
  std::optional<NodeId> selection_;
  std::optional<NodeCloud> cloud_;

  SceneOptions scene_options_;
  glm::dvec3 origin_{0.0};
  Bounds bounds_;
  std::uint64_t scene_version_ = 0;
  std::optional<Scene> pending_scene_;
  std::vector<std::pair<Layer, std::vector<Batch>>> pending_layers_;
  std::optional<Batch> pending_overlay_;
};

}  // namespace sm::viewer
