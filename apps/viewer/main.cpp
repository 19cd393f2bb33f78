// strandmesh-view: shows every stage of a run on its own layer (viewer/), interactively or
// as a headless screenshot. Only parses the command line and hands over to the viewer.

#include <string>

#include <CLI/CLI.hpp>

#include "apps/common/prologue.h"
#include "core/log.h"
#include "viewer/app.h"
#include "viewer/window.h"

namespace {

using sm::app::kOk;
// The exit codes of the strandmesh CLI (apps/common/prologue.h), and this one.
constexpr int kNoDisplay = 4;  ///< no display or no OpenGL 3.3

}  // namespace

int main(int argc, char** argv) {
  sm::app::start_process(argv);
  using namespace sm::viewer;
  CLI::App cli{"strandmesh-view: see what each stage of strandmesh did, layer by layer", "strandmesh-view"};
  cli.set_version_flag("--version", std::string("strandmesh-view ") + STRANDMESH_VERSION);
  ViewerOptions opts;
  std::string input, config, mesh, screenshot, layers, size = "1280x800", camera, color_by;
  std::uint64_t seed = 0;
  std::uint32_t select = 0;
  int threads = 0;
  bool ui = false, no_checks = false, no_self_intersections = false, quiet = false;
  cli.add_option("INPUT", input,
                 "Skeleton file (.json, .swc; the pipeline runs on it), a stage dump directory "
                 "(strandmesh mesh --dump-stages DIR) or a mesh (.glb, .gltf, .obj, .ply)")
      ->required();
  cli.add_option("--config", config, "Parameter file (JSON; see configs/)");
  auto* seed_opt = cli.add_option("--seed", seed, "Random seed of the particle stage");
  cli.add_option("--mesh", mesh, "With a stage dump: the mesh file to show with it");
  cli.add_option("--screenshot", screenshot, "Render one frame without a window into this PNG and exit");
  cli.add_option("--layers", layers,
                 "Layers to show, comma-separated: skeleton, discs, frames, particles, strands, contours, mesh, "
                 "wireframe, normals, problems (what the mesh checks found, marked on the mesh), uv (mesh with UV "
                 "checker), legend, all");
  cli.add_option("--size", size, "Screenshot size (or initial window size) WIDTHxHEIGHT")->capture_default_str();
  cli.add_option("--camera", camera,
                 "Camera: key=value list of yaw, pitch (degrees), dist (relative to the framed distance), "
                 "node (frame that node's subtree), around (with node: a ball of that many radii around it), "
                 "fov (degrees); e.g. yaw=30,pitch=15,node=12,around=6");
  cli.add_option("--color-by", color_by, "Colour strands and particles by 'strand' or by 'tip' (start node)")
      ->check(CLI::IsMember({"strand", "tip"}));
  auto* select_opt = cli.add_option("--select", select, "Select this node once loaded (highlight and node panel)");
  cli.add_flag("--ui", ui, "Screenshot: draw the panels too");
  cli.add_flag("--no-checks", no_checks, "Do not run the mesh checks after each run");
  cli.add_flag("--no-self-intersections", no_self_intersections, "Skip the (slowest) self-intersection check");
  cli.add_option("--threads", threads, "Worker threads (default: all cores)")->check(CLI::NonNegativeNumber);
  cli.add_flag("-q,--quiet", quiet, "Print only errors");
  cli.footer(
      "Mouse: left drag rotates, right/middle (or shift) drag pans, the wheel zooms, a click selects a node.\n"
      "Keys: F frame all, Z frame selection, Esc clear selection.\n"
      "Exit codes: 0 ok, 1 bad input, 2 usage error, 3 internal error, 4 no display or no OpenGL 3.3\n"
      "(run headless under xvfb-run -a).");
  if (const auto stop = sm::app::parse_command_line(cli, argc, argv)) return *stop;
  const auto thread_limit = sm::app::apply_common_options(threads, quiet, false);

  return sm::app::run_reporting_errors([&]() -> int {
    try {
      opts.input = input;
      opts.config = config;
      opts.mesh = mesh;
      if (seed_opt->count() > 0) opts.seed = seed;
      const auto wh = parse_size(size);
      std::optional<ViewState> view;
      if (!layers.empty()) view = parse_layers(layers);
      const CameraSpec cam = camera.empty() ? CameraSpec{} : parse_camera_spec(camera);
      classify_input(opts.input);  // a missing input fails before any window opens

      if (!screenshot.empty()) {
        // Checks only matter when the status panel or the problems layer is drawn (asked for
        // by name: the default layers of a screenshot skip the checks' time).
        const bool problems = view && view->visible[static_cast<std::size_t>(Layer::problems)];
        opts.checks = (ui || problems) && !no_checks;
        opts.self_intersections = !no_self_intersections;
        ViewerApp app(opts);
        ScreenshotOptions so;
        so.output = screenshot;
        so.width = wh[0];
        so.height = wh[1];
        so.view = view;
        so.camera = cam;
        so.ui = ui;
        if (!color_by.empty()) so.coloring = color_by == "tip" ? StrandColoring::by_tip : StrandColoring::by_strand;
        if (select_opt->count() > 0) so.select = select;
        take_screenshot(app, so);
        if (!app.error().empty()) sm::log::warn(app.error());
        sm::log::info("wrote " + screenshot);
        return kOk;
      }
      opts.checks = !no_checks;
      opts.self_intersections = !no_self_intersections;
      ViewerApp app(opts);
      if (view) app.set_view(*view);
      if (color_by == "tip") app.set_coloring(StrandColoring::by_tip);
      WindowOptions wo;
      wo.width = wh[0];
      wo.height = wh[1];
      wo.title = "strandmesh-view: " + input;
      app.set_initial_view(camera.empty() ? std::nullopt : std::optional<CameraSpec>(cam),
                           select_opt->count() > 0 ? std::optional<std::uint32_t>(select) : std::nullopt);
      run_window(app, wo);
      return kOk;
    } catch (const DisplayError& e) {
      sm::log::error(e.what());
      return kNoDisplay;
    }
  });
}
