#pragma once
/// The ImGui panels: the main panel (input, layers, colouring, camera), one panel per stage
/// editing that stage's Params with a re-run button, the status panel (progress, errors,
/// timings, counts, mesh checks, warnings), the node panel (the selected node's 2D particle
/// cloud and figures) and the legend.
///
/// Call between ImGui::NewFrame() and ImGui::Render(). Needs only an ImGui context (no
/// window, no GL): the tests run them headless.

#include "viewer/app.h"

namespace sm::viewer {

/// Which panels are open and the panels' own settings (not part of ViewerApp: pure UI).
struct PanelState {
  bool show_main = true;
  bool show_stages = true;
  bool show_status = true;
  bool show_node = true;
  bool rerun_on_edit = true;  ///< re-run from the edited stage as soon as an edit is finished
  float node_zoom = 1.0f;     ///< zoom of the node panel's cloud canvas
};

/// What the panels asked for this frame that the window must do (camera framing needs the
/// viewport's aspect, quitting needs the window).
struct PanelActions {
  bool frame_all = false;
  bool frame_selection = false;
  bool quit = false;
};

/// Draws every open panel for this frame; width and height are the window's size in pixels.
PanelActions draw_panels(ViewerApp& app, PanelState& state, int width, int height);

/// Draws the legend of the visible layers, its bottom-left corner at (left, height - 10)
/// pixels (screenshots draw it alone).
void draw_legend(const ViewerApp& app, float left, int height);

}  // namespace sm::viewer
