// GLFW window, ImGui set-up and the frame loop; headless screenshots.
//
// The window is created hidden for screenshots (GLFW_VISIBLE false) and the frame is drawn
// into an offscreen multisampled framebuffer of the requested size, so the picture does not
// depend on the X server's screen size; Xvfb with Mesa's llvmpipe renders it.

#define GL_GLEXT_PROTOTYPES
#include "viewer/window.h"

#include <algorithm>
#include <cmath>
#include <memory>

#include <GL/gl.h>
#include <GL/glext.h>
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <imgui_impl_glfw.h>
#include <imgui_impl_opengl3.h>

#include "viewer/gl_backend.h"
#include "viewer/image.h"

namespace sm::viewer {

namespace {

std::string& glfw_error_text() {
  static std::string text;
  return text;
}

void on_glfw_error(int code, const char* description) {
  glfw_error_text() = "GLFW error " + std::to_string(code) + ": " + (description ? description : "");
}

// GLFW, one window with a current 3.3 core context, and ImGui with its GLFW and OpenGL 3
// backends; torn down in reverse order.
class Context {
 public:
  Context(int width, int height, bool visible, const std::string& title) {
    glfwSetErrorCallback(on_glfw_error);
    if (!glfwInit()) {
      throw DisplayError("cannot open a display (" + glfw_error_text() +
                         "); run under xvfb-run for headless use, e.g. xvfb-run -a strandmesh-view ...");
    }
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_FALSE);
    glfwWindowHint(GLFW_VISIBLE, visible ? GLFW_TRUE : GLFW_FALSE);
    glfwWindowHint(GLFW_SAMPLES, visible ? 4 : 0);
    window_ = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
    if (!window_) {
      glfwTerminate();
      throw DisplayError("cannot create an OpenGL 3.3 core window (" + glfw_error_text() + ")");
    }
    glfwMakeContextCurrent(window_);
    glfwSwapInterval(1);
    IMGUI_CHECKVERSION();
    ImGui::CreateContext();
    ImGuiIO& io = ImGui::GetIO();
    io.IniFilename = nullptr;  // never write imgui.ini into the user's working directory
    ImGui::StyleColorsLight();
    ImGui::GetStyle().WindowRounding = 4.0f;
    ImGui::GetStyle().Colors[ImGuiCol_WindowBg].w = 0.94f;
    ImGui_ImplGlfw_InitForOpenGL(window_, true);
    ImGui_ImplOpenGL3_Init("#version 330 core");
  }
  ~Context() {
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
    ImGui::DestroyContext();
    glfwDestroyWindow(window_);
    glfwTerminate();
  }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  [[nodiscard]] GLFWwindow* window() const { return window_; }

 private:
  GLFWwindow* window_ = nullptr;
};

}  // namespace

void run_window(ViewerApp& app, const WindowOptions& options) {
  Context ctx(options.width, options.height, true, options.title);
  GLFWwindow* win = ctx.window();
  GlBackend backend;
  Renderer renderer(backend);
  PanelState panels;
  app.start();
  ImGuiIO& io = ImGui::GetIO();
  while (!glfwWindowShouldClose(win)) {
    // Wait for input, but wake up often while a job runs so its progress shows.
    glfwWaitEventsTimeout(app.busy() ? 1.0 / 30.0 : 0.5);
    app.update();
    int fb_w = 0, fb_h = 0, win_w = 0, win_h = 0;
    glfwGetFramebufferSize(win, &fb_w, &fb_h);
    glfwGetWindowSize(win, &win_w, &win_h);
    if (fb_w <= 0 || fb_h <= 0) continue;  // minimized
    const double aspect = static_cast<double>(fb_w) / fb_h;

    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    const PanelActions actions = draw_panels(app, panels, win_w, win_h);

    // Camera input when ImGui does not want the mouse or keyboard. Mouse positions are in
    // window coordinates; picking scales them to the framebuffer.
    if (!io.WantCaptureMouse) {
      const bool shift = io.KeyShift;
      if (ImGui::IsMouseDragging(ImGuiMouseButton_Left) && !shift) {
        app.on_drag(ViewerApp::Drag::rotate, io.MouseDelta.x, io.MouseDelta.y, win_w, win_h);
      } else if (ImGui::IsMouseDragging(ImGuiMouseButton_Right) || ImGui::IsMouseDragging(ImGuiMouseButton_Middle) ||
                 (ImGui::IsMouseDragging(ImGuiMouseButton_Left) && shift)) {
        app.on_drag(ViewerApp::Drag::pan, io.MouseDelta.x, io.MouseDelta.y, win_w, win_h);
      }
      if (io.MouseWheel != 0.0f) app.on_scroll(io.MouseWheel);
      if (ImGui::IsMouseReleased(ImGuiMouseButton_Left) && io.MouseDragMaxDistanceSqr[0] < 16.0f) {
        const double sx = win_w > 0 ? static_cast<double>(fb_w) / win_w : 1.0;
        const double sy = win_h > 0 ? static_cast<double>(fb_h) / win_h : 1.0;
        app.on_click(static_cast<double>(io.MousePos.x) * sx, static_cast<double>(io.MousePos.y) * sy, fb_w, fb_h);
      }
    }
    if (!io.WantCaptureKeyboard) {
      if (ImGui::IsKeyPressed(GLFW_KEY_F)) app.frame_all(aspect);
      if (ImGui::IsKeyPressed(GLFW_KEY_Z)) app.frame_selection(aspect);
      if (ImGui::IsKeyPressed(GLFW_KEY_ESCAPE)) app.select(std::nullopt);
    }
    if (actions.frame_all) app.frame_all(aspect);
    if (actions.frame_selection) app.frame_selection(aspect);
    if (actions.quit) glfwSetWindowShouldClose(win, GLFW_TRUE);

    ImGui::Render();
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    app.render(renderer, fb_w, fb_h);
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    glfwSwapBuffers(win);
  }
  app.cancel();
  renderer.clear();
}

void take_screenshot(ViewerApp& app, const ScreenshotOptions& options) {
  const int w = options.width, h = options.height;
  Context ctx(std::min(w, 4096), std::min(h, 4096), false, "strandmesh-view screenshot");
  GlBackend backend;
  Renderer renderer(backend);
  app.start();
  app.wait_idle();
  if (!app.run()) throw InvalidInputError(app.error().empty() ? "nothing was loaded" : app.error());
  if (options.view) app.set_view(*options.view);
  if (options.coloring) app.set_coloring(*options.coloring);
  const double aspect = static_cast<double>(w) / h;
  if (options.select) {
    const RunData* run = app.run();
    if (!run->has_stage(Stage::skeleton) || *options.select >= run->result.skeleton.skeleton.size()) {
      throw UsageError("--select " + std::to_string(*options.select) + ": no such node");
    }
    app.select(NodeId(*options.select));
  }
  app.apply_camera_spec(options.camera, aspect);

  OffscreenTarget target(w, h, options.samples);
  target.bind();
  app.render(renderer, w, h);
  if (options.ui || app.view().legend) {
    // ImGui sizes auto-resizing windows one frame late, so a few frames are laid out before
    // the one that is drawn. The display size is set directly: the hidden window's size may be
    // clamped by the X screen, the offscreen target is not.
    ImGuiIO& io = ImGui::GetIO();
    io.DisplaySize = ImVec2(static_cast<float>(w), static_cast<float>(h));
    io.DisplayFramebufferScale = ImVec2(1, 1);
    io.DeltaTime = 1.0f / 60.0f;
    PanelState panels;
    for (int frame = 0; frame < 3; ++frame) {
      ImGui_ImplOpenGL3_NewFrame();
      ImGui::NewFrame();
      if (options.ui) {
        draw_panels(app, panels, w, h);
      } else {
        draw_legend(app, 10.0f, h);
      }
      ImGui::Render();
    }
    target.bind();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
  }
  target.resolve();
  glFinish();
  Image img = backend.read_pixels();
  img.width = w;
  img.height = h;
  renderer.clear();
  write_png(options.output, img);
}

}  // namespace sm::viewer
