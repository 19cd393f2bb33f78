// The viewer's state machine. The render thread owns everything here; the job thread only
// ever sees copies (a RunData copied before a re-run, the parameters by value), so no lock is
// needed beyond the job's own progress fields.

#include "viewer/app.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/errors.h"
#include "viewer/param_fields.h"

namespace sm::viewer {

namespace {

std::size_t li(Layer l) {
  return static_cast<std::size_t>(l);
}

std::string accepted_layers() {
  std::string s;
  for (std::size_t i = 0; i < kLayerCount; ++i) s += std::string(layer_name(static_cast<Layer>(i))) + ", ";
  return s + "uv, legend, all";
}

}  // namespace

ViewState parse_layers(const std::string& list) {
  ViewState v;
  v.legend = false;
  std::size_t pos = 0;
  while (pos <= list.size()) {
    const std::size_t comma = std::min(list.find(',', pos), list.size());
    std::string item = list.substr(pos, comma - pos);
    pos = comma + 1;
    item.erase(0, item.find_first_not_of(' '));
    item.erase(item.find_last_not_of(' ') + 1);
    if (item.empty()) {
      if (comma >= list.size()) break;
      continue;
    }
    if (item == "uv") {
      v.visible[li(Layer::mesh)] = true;
      v.shading = MeshShading::uv_checker;
    } else if (item == "legend") {
      v.legend = true;
    } else if (item == "all") {
      v.visible.fill(true);
    } else if (const auto l = layer_from_name(item)) {
      v.visible[li(*l)] = true;
    } else {
      throw UsageError("--layers: unknown layer '" + item + "' (accepted: " + accepted_layers() + ")");
    }
  }
  return v;
}

std::array<int, 2> parse_size(const std::string& text) {
  const std::size_t x = text.find_first_of("xX");
  auto bad = [&] { return UsageError("--size: '" + text + "' is not WIDTHxHEIGHT with both in [16, 8192]"); };
  if (x == std::string::npos) throw bad();
  std::array<int, 2> out{};
  try {
    std::size_t used = 0;
    const std::string a = text.substr(0, x), b = text.substr(x + 1);
    out[0] = std::stoi(a, &used);
    if (used != a.size()) throw bad();
    out[1] = std::stoi(b, &used);
    if (used != b.size()) throw bad();
  } catch (const std::logic_error&) {
    throw bad();
  }
  for (int v : out) {
    if (v < 16 || v > 8192) throw bad();
  }
  return out;
}

ViewState default_view(const RunData& run) {
  ViewState v;
  if (run.has_stage(Stage::meshing)) {
    v.visible[li(Layer::mesh)] = true;
    v.visible[li(Layer::skeleton)] = run.has_stage(Stage::skeleton);
    v.visible[li(Layer::problems)] = true;  // empty until the checks find something
  } else if (run.has_stage(Stage::contours)) {
    v.visible[li(Layer::contours)] = true;
    v.visible[li(Layer::skeleton)] = true;
  } else if (run.has_stage(Stage::strands)) {
    v.visible[li(Layer::strands)] = true;
    v.visible[li(Layer::skeleton)] = true;
  } else {
    v.visible[li(Layer::skeleton)] = true;
    v.visible[li(Layer::discs)] = true;
  }
  return v;
}

ViewerApp::ViewerApp(ViewerOptions options) : options_(std::move(options)) {
  view_.visible[li(Layer::skeleton)] = true;
  view_.visible[li(Layer::mesh)] = true;
}

void ViewerApp::start() {
  PipelineParams params;
  if (!options_.config.empty()) {
    try {
      params = load_params(options_.config);
    } catch (const std::exception& e) {
      error_ = std::string(e.what()) + " (using the default parameters)";
    }
  }
  if (options_.seed) params.particles.seed = *options_.seed;
  edited_ = params;
  applied_ = params;
  needs_framing_ = true;
  const ViewerOptions opts = options_;
  start_job(
      JobOutcome::Kind::load,
      [opts, params](const ProgressFn& progress) {
        JobOutcome out;
        out.run = std::make_shared<const RunData>(load_input(opts.input, params, opts.mesh, progress));
        return out;
      },
      params);
}

void ViewerApp::reload() {
  if (job_.running()) job_.cancel();
  queued_rerun_.reset();
  queued_reload_ = true;
}

void ViewerApp::start_job(JobOutcome::Kind kind, Job::Work work, const PipelineParams& params) {
  job_params_ = params;
  job_.start(kind, std::move(work));
}

bool ViewerApp::busy() const {
  return job_.busy() || queued_rerun_ || queued_checks_ || queued_reload_;
}

void ViewerApp::cancel() {
  queued_rerun_.reset();
  queued_checks_ = false;
  queued_reload_ = false;
  job_.cancel();
}

void ViewerApp::request_rerun(Stage from) {
  if (!run_ || !run_->can_rerun()) {
    error_ =
        run_ ? "this input has no skeleton to re-run the stages on (a mesh file is shown as is)" : "nothing loaded yet";
    return;
  }
  // A running re-run or check is superseded: cancel it and start over from the earliest
  // stage anybody asked for.
  if (job_.running() && job_.progress().kind != JobOutcome::Kind::load) job_.cancel();
  queued_rerun_ = queued_rerun_ ? std::min(*queued_rerun_, from) : from;
}

std::optional<Stage> ViewerApp::apply_changes() {
  const auto s = first_changed_stage(applied_, edited_);
  if (s) request_rerun(*s);
  return s;
}

void ViewerApp::request_checks() {
  if (!run_ || !run_->has_stage(Stage::meshing)) {
    error_ = "no mesh to check";
    return;
  }
  queued_checks_ = true;
}

void ViewerApp::start_rerun(Stage from) {
  const std::shared_ptr<const RunData> base = run_;
  const PipelineParams params = edited_;
  start_job(
      JobOutcome::Kind::rerun,
      [base, params, from](const ProgressFn& progress) {
        auto copy = std::make_shared<RunData>(*base);
        rerun(*copy, params, from, progress);
        JobOutcome out;
        out.run = std::move(copy);
        return out;
      },
      params);
}

void ViewerApp::update() {
  if (auto outcome = job_.take()) on_outcome(std::move(*outcome));
  if (job_.busy()) return;
  if (queued_reload_) {
    queued_reload_ = false;
    options_.seed.reset();  // the edited parameters carry the seed now
    const ViewerOptions opts = options_;
    const PipelineParams params = edited_;
    needs_framing_ = true;
    start_job(
        JobOutcome::Kind::load,
        [opts, params](const ProgressFn& progress) {
          JobOutcome out;
          out.run = std::make_shared<const RunData>(load_input(opts.input, params, opts.mesh, progress));
          return out;
        },
        params);
  } else if (queued_rerun_ && run_) {
    const Stage from = *queued_rerun_;
    queued_rerun_.reset();
    start_rerun(from);
  } else if (queued_checks_ && run_ && run_->has_stage(Stage::meshing)) {
    queued_checks_ = false;
    const std::shared_ptr<const RunData> base = run_;
    const bool si = options_.self_intersections;
    start_job(
        JobOutcome::Kind::checks,
        [base, si](const ProgressFn& progress) {
          progress("checks", 0);
          JobOutcome out;
          out.check = run_checks(*base, si);
          progress("checks", 1);
          return out;
        },
        applied_);
  } else {
    queued_checks_ = false;
    queued_rerun_.reset();
  }
}

void ViewerApp::wait_idle() {
  while (busy()) {
    job_.wait();
    update();
  }
}

void ViewerApp::on_outcome(JobOutcome outcome) {
  if (!outcome.error.empty()) {
    // The previous run stays on screen; the error is shown above it.
    if (!outcome.cancelled || (!queued_rerun_ && !queued_reload_)) {
      const char* what = outcome.kind == JobOutcome::Kind::checks  ? "mesh checks"
                         : outcome.kind == JobOutcome::Kind::rerun ? "re-run"
                                                                   : "loading";
      error_ = std::string(what) + " failed: " + outcome.error;
    }
    return;
  }
  if (outcome.kind == JobOutcome::Kind::checks) {
    check_ = std::move(outcome.check);
    if (run_ && check_ && run_->has_stage(Stage::meshing)) {
      const StageView v = view_of(*run_);
      replace_layer(Layer::problems, problem_batches(*v.mesh, v.skeleton, *check_, origin_));
      ++scene_version_;
    }
    return;
  }
  const bool first = run_ == nullptr;
  run_ = std::move(outcome.run);
  applied_ = job_params_;
  check_.reset();
  // A successful re-run answers an earlier failed one; a load keeps the config's error.
  if (outcome.kind == JobOutcome::Kind::rerun) error_.clear();
  last_run_seconds_ = outcome.seconds;
  if (first && !view_fixed_) view_ = default_view(*run_);
  rebuild_scene();
  if (selection_ && (!run_->has_stage(Stage::skeleton) || selection_->idx() >= run_->result.skeleton.skeleton.size())) {
    selection_.reset();
  }
  rebuild_selection();
  if (options_.checks && run_->has_stage(Stage::meshing)) queued_checks_ = true;
}

void ViewerApp::rebuild_scene() {
  if (!run_) return;
  scene_options_.strand_coloring = view_.coloring;
  Scene scene = build_scene(view_of(*run_), scene_options_);
  origin_ = scene.origin;
  bounds_ = scene.bounds;
  camera_.up = scene.up_axis;
  pending_scene_ = std::move(scene);
  pending_layers_.clear();
  ++scene_version_;
}

void ViewerApp::set_view(const ViewState& view) {
  const bool recolor = view.coloring != view_.coloring;
  view_ = view;
  view_fixed_ = true;
  if (recolor) set_coloring(view.coloring);
}

void ViewerApp::set_coloring(StrandColoring coloring) {
  view_.coloring = coloring;
  scene_options_.strand_coloring = coloring;
  rebuild_selection();
  if (!run_) return;
  // Only the two layers that depend on the colouring are rebuilt.
  const StageView v = view_of(*run_);
  if (!v.skeleton || !v.particles) return;
  const StrandSet* strands = v.strands && v.strands->point.size() == v.particles->position.size() ? v.strands : nullptr;
  auto particles = particle_batches(*v.skeleton, *v.particles, strands, origin_, scene_options_);
  auto strand_lines =
      strands ? strand_batches(*v.skeleton, *v.particles, *strands, origin_, scene_options_) : std::vector<Batch>{};
  replace_layer(Layer::particles, std::move(particles));
  replace_layer(Layer::strands, std::move(strand_lines));
  ++scene_version_;
}

void ViewerApp::replace_layer(Layer layer, std::vector<Batch> batches) {
  if (pending_scene_) {
    pending_scene_->layer(layer) = std::move(batches);
  } else {
    pending_layers_.emplace_back(layer, std::move(batches));
  }
}

void ViewerApp::select(std::optional<NodeId> node) {
  selection_ = node;
  rebuild_selection();
}

void ViewerApp::rebuild_selection() {
  cloud_.reset();
  const Skeleton* s = run_ && run_->has_stage(Stage::skeleton) ? &run_->result.skeleton.skeleton : nullptr;
  if (!selection_ || !s || selection_->idx() >= s->size()) {
    selection_.reset();
    pending_overlay_ = Batch{};
    return;
  }
  pending_overlay_ = selection_batch(*s, *selection_, origin_);
  if (run_->has_stage(Stage::particles)) {
    try {
      cloud_ =
          node_cloud(*s, run_->result.particles, *selection_, view_.coloring, applied_.contours.concave_turn_degrees);
    } catch (const std::exception& e) {
      error_ = e.what();
    }
  }
}

void ViewerApp::frame_all(double aspect) {
  camera_.frame(bounds_, aspect);
  needs_framing_ = false;
}

bool ViewerApp::frame_selection(double aspect) {
  if (!selection_ || !run_ || !run_->has_stage(Stage::skeleton)) return false;
  const Bounds wb = subtree_bounds(run_->result.skeleton.skeleton, *selection_);
  if (wb.empty()) return false;
  Bounds lb;
  lb.lo = wb.lo - origin_;
  lb.hi = wb.hi - origin_;
  camera_.frame(lb, aspect);
  needs_framing_ = false;
  return true;
}

void ViewerApp::apply_camera_spec(const CameraSpec& spec, double aspect) {
  if (spec.fov_degrees) camera_.fov_y = *spec.fov_degrees * std::numbers::pi / 180.0;
  if (spec.yaw_degrees) camera_.yaw = *spec.yaw_degrees * std::numbers::pi / 180.0;
  if (spec.pitch_degrees) camera_.pitch = *spec.pitch_degrees * std::numbers::pi / 180.0;
  bool framed = false;
  if (spec.node) {
    const Skeleton* s = run_ && run_->has_stage(Stage::skeleton) ? &run_->result.skeleton.skeleton : nullptr;
    if (!s || *spec.node >= s->size()) {
      throw UsageError("--camera: node=" + std::to_string(*spec.node) + " does not exist (the skeleton has " +
                       std::to_string(s ? s->size() : 0) + " nodes)");
    }
    if (spec.around) {
      const std::size_t n = *spec.node;
      Bounds b;
      b.add_sphere(s->position[n] - origin_, *spec.around * s->radius[n]);
      camera_.frame(b, aspect);
      needs_framing_ = false;
      framed = true;
    } else {
      const Bounds wb = subtree_bounds(*s, NodeId(*spec.node));
      Bounds b;
      b.lo = wb.lo - origin_;
      b.hi = wb.hi - origin_;
      camera_.frame(b, aspect);
      needs_framing_ = false;
      framed = true;
    }
  }
  if (spec.around && !spec.node) throw UsageError("--camera: around= needs node=");
  if (!framed) frame_all(aspect);
  camera_.distance *= spec.distance_scale;
}

void ViewerApp::set_initial_view(std::optional<CameraSpec> camera, std::optional<std::uint32_t> select) {
  initial_camera_ = std::move(camera);
  initial_select_ = select;
}

void ViewerApp::on_drag(Drag kind, double dx, double dy, int /*width*/, int height) {
  if (kind == Drag::rotate) {
    camera_.rotate(dx, dy, height);
  } else {
    camera_.pan(dx, dy, height);
  }
}

void ViewerApp::on_click(double x, double y, int width, int height) {
  if (!run_ || !run_->has_stage(Stage::skeleton) || width <= 0 || height <= 0) return;
  const glm::mat4 vp = projection_matrix(width, height) * view_matrix();
  select(pick_node(run_->result.skeleton.skeleton, origin_, vp, {x, y}, width, height));
}

glm::mat4 ViewerApp::projection_matrix(int width, int height) const {
  const double aspect = static_cast<double>(std::max(width, 1)) / std::max(height, 1);
  return camera_.projection(aspect, bounds_.radius() + glm::length(bounds_.center()));
}

void ViewerApp::render(Renderer& renderer, int width, int height) {
  if (pending_scene_) {
    renderer.set_scene(std::move(*pending_scene_));
    pending_scene_.reset();
  }
  for (auto& [layer, batches] : pending_layers_) renderer.set_layer(layer, std::move(batches));
  pending_layers_.clear();
  if (pending_overlay_) {
    renderer.set_overlay(std::move(*pending_overlay_));
    pending_overlay_.reset();
  }
  if (needs_framing_ && run_ && !bounds_.empty()) {
    const double aspect = static_cast<double>(std::max(width, 1)) / std::max(height, 1);
    frame_all(aspect);
    try {
      if (initial_select_) {
        const std::uint32_t n = *initial_select_;
        initial_select_.reset();
        if (!run_->has_stage(Stage::skeleton) || n >= run_->result.skeleton.skeleton.size()) {
          throw UsageError("--select " + std::to_string(n) + ": no such node");
        }
        select(NodeId(n));
      }
      if (initial_camera_) {
        const CameraSpec spec = *initial_camera_;
        initial_camera_.reset();
        apply_camera_spec(spec, aspect);
      }
    } catch (const Error& e) {
      error_ = e.what();
    }
    if (pending_overlay_) {
      renderer.set_overlay(std::move(*pending_overlay_));
      pending_overlay_.reset();
    }
  }
  RenderOptions ro;
  ro.visible = view_.visible;
  ro.shading = view_.shading;
  renderer.draw(width, height, view_matrix(), projection_matrix(width, height), ro);
}

}  // namespace sm::viewer
