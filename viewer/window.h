#pragma once
/// The GLFW side of the viewer: the interactive window and headless screenshots.
///
/// Both need an OpenGL 3.3 core context from GLFW; without a display (no X server, no
/// Xvfb) or without OpenGL 3.3 they throw DisplayError, which the app turns into its own exit
/// code so scripts and tests can tell "cannot draw here" from "the input is broken".

#include <filesystem>
#include <optional>
#include <string>

#include "core/errors.h"
#include "viewer/app.h"
#include "viewer/camera.h"
#include "viewer/panels.h"

namespace sm::viewer {

/// No display, or no OpenGL 3.3 core context on it.
class DisplayError : public Error {
 public:
  using Error::Error;
};

struct WindowOptions {
  int width = 1400;  ///< initial window size (screen coordinates)
  int height = 900;
  std::string title = "strandmesh-view";
};

/// Opens the window, starts the app (app.start()) and runs until the window is closed or
/// the Quit button is pressed. Throws DisplayError when no window can be made.
void run_window(ViewerApp& app, const WindowOptions& options);

struct ScreenshotOptions {
  std::filesystem::path output;  ///< PNG file to write
  int width = 1280;              ///< image size in pixels
  int height = 800;
  std::optional<ViewState> view;           ///< layers (--layers); the run's default view when absent
  CameraSpec camera;                       ///< placement (--camera); frame all by default
  std::optional<std::uint32_t> select;     ///< node to select (highlighted; shown in the node panel)
  std::optional<StrandColoring> coloring;  ///< strand colouring (--color-by); as the view says when absent
  bool ui = false;                         ///< draw the panels too (else only the legend, when on)
  int samples = 4;                         ///< multisampling (0 = off)
};

/// Loads the app's input, renders one frame offscreen in a hidden window's context and writes
/// it as PNG. Throws DisplayError (no display), the load's error (as InvalidInputError or
/// IoError) when nothing could be loaded, UsageError for a bad camera spec or node.
void take_screenshot(ViewerApp& app, const ScreenshotOptions& options);

}  // namespace sm::viewer
