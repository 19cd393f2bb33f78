// ImGui panels. Immediate mode: every frame reads the app's state and writes edits straight
// into its edited PipelineParams through the parameter table (viewer/param_fields.h), so the
// Params structs themselves never learn about the UI.

#include "viewer/panels.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include <imgui.h>

#include "viewer/colors.h"
#include "viewer/param_fields.h"

namespace sm::viewer {

namespace {

ImU32 to_imgui(Rgba8 c) {
  return IM_COL32(c.r, c.g, c.b, c.a);
}

const ImVec4 kErrorColor(0.85f, 0.1f, 0.1f, 1.0f);
const ImVec4 kOkColor(0.1f, 0.55f, 0.15f, 1.0f);
const ImVec4 kDimColor(0.5f, 0.5f, 0.5f, 1.0f);

void help_marker(const char* text) {
  ImGui::SameLine();
  ImGui::TextDisabled("(?)");
  if (ImGui::IsItemHovered()) {
    ImGui::BeginTooltip();
    ImGui::PushTextWrapPos(ImGui::GetFontSize() * 30.0f);
    ImGui::TextUnformatted(text);
    ImGui::PopTextWrapPos();
    ImGui::EndTooltip();
  }
}

void swatch(Rgba8 c) {
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const float s = ImGui::GetTextLineHeight();
  ImGui::GetWindowDrawList()->AddRectFilled(p, ImVec2(p.x + s, p.y + s), to_imgui(c), 2.0f);
  ImGui::Dummy(ImVec2(s, s));
  ImGui::SameLine();
}

bool stage_has_layer_data(const RunData* run, Layer l) {
  if (!run) return false;
  switch (l) {
    case Layer::skeleton:
    case Layer::discs:
    case Layer::frames:
      return run->has_stage(Stage::skeleton);
    case Layer::particles:
      return run->has_stage(Stage::particles);
    case Layer::strands:
      return run->has_stage(Stage::strands);
    case Layer::contours:
      return run->has_stage(Stage::contours);
    case Layer::mesh:
    case Layer::wireframe:
    case Layer::normals:
    case Layer::problems:
      return run->has_stage(Stage::meshing);
    case Layer::count:
      break;
  }
  return false;
}

// One parameter row, its widget chosen by the field's kind; returns true when an edit was
// completed this frame.
bool field_widget(const ParamField& f, const ParamField& applied) {
  const char* key = f.key.c_str();
  ImGui::PushID(key);
  const bool changed_from_applied = field_value(f) != field_value(applied);
  if (changed_from_applied) ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(0.9f, 0.45f, 0.0f, 1.0f));
  bool instant = false;  // checkboxes and combos finish their edit in the frame they change
  ImGui::SetNextItemWidth(ImGui::GetFontSize() * 11.0f);
  const ImGuiSliderFlags flags = f.logarithmic ? ImGuiSliderFlags_Logarithmic : ImGuiSliderFlags_None;
  switch (f.kind) {
    case ParamKind::real: {
      double v = field_value(f);
      const double lo = f.min, hi = f.max;
      if (ImGui::SliderScalar(key, ImGuiDataType_Double, &v, &lo, &hi, "%.4g", flags)) set_field_value(f, v);
      break;
    }
    case ParamKind::integer: {
      auto v = static_cast<std::uint64_t>(field_value(f));
      const auto lo = static_cast<std::uint64_t>(f.min), hi = static_cast<std::uint64_t>(f.max);
      // Counts spanning decades (node and particle limits) are typed; small ones slide.
      const bool edited = f.logarithmic || f.max > 1e6 ? ImGui::InputScalar(key, ImGuiDataType_U64, &v)
                                                        : ImGui::SliderScalar(key, ImGuiDataType_U64, &v, &lo, &hi, "%llu");
      if (edited) set_field_value(f, static_cast<double>(v));
      break;
    }
    case ParamKind::flag: {
      bool b = field_value(f) != 0.0;
      if (ImGui::Checkbox(key, &b)) set_field_value(f, b ? 1.0 : 0.0);
      instant = true;
      break;
    }
    case ParamKind::choice: {
      int v = static_cast<int>(field_value(f));
      std::vector<const char*> items;
      for (const auto& c : f.choices) items.push_back(c.c_str());
      if (ImGui::Combo(key, &v, items.data(), static_cast<int>(items.size()))) set_field_value(f, v);
      instant = true;
      break;
    }
    case ParamKind::text:
      // (Only the export section has text fields, and the viewer's panels are the stages'.)
      ImGui::TextDisabled("%s", key);
      break;
  }
  bool done = ImGui::IsItemDeactivatedAfterEdit() || (instant && ImGui::IsItemEdited());
  if (changed_from_applied) ImGui::PopStyleColor();
  help_marker(f.help.c_str());
  ImGui::PopID();
  return done;
}

void stage_stats(const RunData& run, Stage s) {
  const PipelineResult& r = run.result;
  char line[256];
  switch (s) {
    case Stage::skeleton: {
      const auto& rep = r.skeleton.report;
      std::snprintf(line, sizeof line,
                    "%zu nodes (%zu in the input); merged %zu, raised %zu, clamped %zu, binarized %zu",
                    r.skeleton.skeleton.size(), rep.input_nodes, rep.merged_edges, rep.raised_radii,
                    rep.clamped_children, rep.binarized_nodes);
      break;
    }
    case Stage::particles: {
      const auto& st = r.particles.stats;
      std::snprintf(line, sizeof line,
                    "spacing %.4g m; %zu strands, %zu particles, %zu relaxation steps, %zu unconverged",
                    r.particles.spacing, r.particles.strand_count(), r.particles.position.size(), st.relaxation_steps,
                    st.unconverged_nodes);
      break;
    }
    case Stage::strands:
      std::snprintf(line, sizeof line, "%zu strands, %zu segments", r.strands.stats.strands, r.strands.stats.segments);
      break;
    case Stage::contours: {
      const auto& c = r.contours;
      std::snprintf(line, sizeof line, "%zu loops, %zu tubes, %zu junctions (%zu forced splits), %zu fallbacks",
                    c.loop_count(), c.tubes.size(), c.junctions.size(), c.stats.forced_splits,
                    c.stats.boundary_fallbacks);
      break;
    }
    case Stage::meshing: {
      const auto& st = r.mesh.stats;
      const auto& folds = r.repair.junction_folds;
      std::snprintf(line, sizeof line,
                    "%zu vertices, %zu triangles, %zu merged junctions; fold repair: %zu crossing pairs found, %zu "
                    "flips, %zu vertices moved",
                    r.mesh.mesh.vertex_count(), r.mesh.mesh.triangle_count(), st.merged_junctions, folds.found,
                    folds.flips, folds.moves);
      ImGui::TextWrapped("%s", line);
      // What the fork retry, the near misses and the outer surface did (see `strandmesh -v mesh`), when they ran.
      if (const auto& fr = r.repair.fork_retry; fr.runs > 0) ImGui::TextWrapped("fork retry: %s", to_text(fr).c_str());
      if (const auto& nm = r.repair.near_misses; nm.outside_before > 0) {
        ImGui::TextWrapped("near misses: %s", to_text(nm).c_str());
      }
      if (const auto& os = r.repair.outer_surface; os.tried) {
        ImGui::TextWrapped("outer surface: %s%s", to_text(os).c_str(),
                           os.refused.empty() ? "" : "; some attempts refused (hover)");
        if (!os.refused.empty() && ImGui::IsItemHovered()) ImGui::SetTooltip("%s", os.refused.c_str());
      }
      return;
    }
  }
  ImGui::TextWrapped("%s", line);
}

void main_panel(ViewerApp& app, PanelState& state, PanelActions& actions) {
  ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(330, 330), ImGuiCond_FirstUseEver);
  if (!ImGui::Begin("strandmesh", &state.show_main)) {
    ImGui::End();
    return;
  }
  const RunData* run = app.run();
  ImGui::TextWrapped("%s", app.options().input.string().c_str());
  if (!app.error().empty()) {
    ImGui::PushStyleColor(ImGuiCol_Text, kErrorColor);
    ImGui::TextWrapped("%s", app.error().c_str());
    ImGui::PopStyleColor();
    if (ImGui::SmallButton("dismiss")) app.clear_error();
  }
  const JobProgress p = app.progress();
  if (p.running) {
    char overlay[128];
    std::snprintf(overlay, sizeof overlay, "%s %.0f%% (%.1f s)", p.phase.c_str(), 100.0 * p.fraction, p.seconds);
    ImGui::ProgressBar(static_cast<float>(p.fraction), ImVec2(-1, 0), overlay);
    if (ImGui::Button("Cancel")) app.cancel();
  }
  ImGui::Separator();
  ImGui::TextUnformatted("Layers");
  for (std::size_t i = 0; i < kLayerCount; ++i) {
    const Layer l = static_cast<Layer>(i);
    bool on = app.view().visible[i];
    const bool has = stage_has_layer_data(run, l);
    if (!has) ImGui::PushStyleColor(ImGuiCol_Text, kDimColor);
    if (ImGui::Checkbox(layer_name(l), &on)) app.set_layer_visible(l, on);
    if (!has) ImGui::PopStyleColor();
    if (i % 3 != 2 && i + 1 < kLayerCount) ImGui::SameLine(ImGui::GetFontSize() * (1 + 6.5f * float(i % 3 + 1)));
  }
  int coloring = static_cast<int>(app.view().coloring);
  ImGui::TextUnformatted("strands/particles:");
  ImGui::SameLine();
  if (ImGui::RadioButton("by strand", &coloring, 0)) app.set_coloring(StrandColoring::by_strand);
  ImGui::SameLine();
  if (ImGui::RadioButton("by tip", &coloring, 1)) app.set_coloring(StrandColoring::by_tip);
  int shading = static_cast<int>(app.view().shading);
  ImGui::TextUnformatted("mesh:");
  ImGui::SameLine();
  if (ImGui::RadioButton("smooth", &shading, 0)) app.set_shading(MeshShading::smooth);
  ImGui::SameLine();
  if (ImGui::RadioButton("UV checker", &shading, 1)) app.set_shading(MeshShading::uv_checker);
  bool legend = app.view().legend;
  if (ImGui::Checkbox("legend", &legend)) app.set_legend(legend);
  ImGui::Separator();
  if (ImGui::Button("Frame all (F)")) actions.frame_all = true;
  ImGui::SameLine();
  if (ImGui::Button("Frame selection (Z)")) actions.frame_selection = true;
  ImGui::TextDisabled("left drag: rotate, right/middle or shift drag: pan,\nwheel: zoom, click: select a node");
  ImGui::Separator();
  ImGui::Checkbox("stages", &state.show_stages);
  ImGui::SameLine();
  ImGui::Checkbox("status", &state.show_status);
  ImGui::SameLine();
  ImGui::Checkbox("node", &state.show_node);
  if (ImGui::Button("Reload input")) app.reload();
  ImGui::SameLine();
  if (ImGui::Button("Quit")) actions.quit = true;
  ImGui::End();
}

void stages_panel(ViewerApp& app, PanelState& state, int width) {
  ImGui::SetNextWindowPos(ImVec2(static_cast<float>(width) - 430.0f, 10), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(420, 250), ImGuiCond_FirstUseEver);
  if (!ImGui::Begin("Stages", &state.show_stages)) {
    ImGui::End();
    return;
  }
  const RunData* run = app.run();
  const bool can_rerun = run && run->can_rerun();
  ImGui::Checkbox("re-run on edit", &state.rerun_on_edit);
  ImGui::SameLine();
  const auto changed = first_changed_stage(app.applied_params(), app.edited_params());
  if (!changed) ImGui::BeginDisabled();
  if (ImGui::Button("Apply changes")) app.apply_changes();
  if (!changed) ImGui::EndDisabled();
  ImGui::SameLine();
  if (ImGui::Button("Reset to applied")) app.edited_params() = app.applied_params();
  if (!can_rerun) ImGui::TextDisabled("(a mesh file alone: nothing to re-run)");
  PipelineParams applied = app.applied_params();
  for (Stage s : kStages) {
    ImGui::PushID(static_cast<int>(s));
    char title[64];
    const double seconds = run ? run->result.timings.get(stage_name(s)) : 0.0;
    std::snprintf(title, sizeof title, "%s  (%.3f s)###%s", stage_name(s), seconds, stage_name(s));
    if (ImGui::CollapsingHeader(title, 0)) {
      if (run && run->has_stage(s)) stage_stats(*run, s);
      const auto fields = param_fields(app.edited_params(), s);
      const auto applied_fields = param_fields(applied, s);
      bool edit_done = false;
      for (std::size_t i = 0; i < fields.size() && i < applied_fields.size(); ++i) {
        edit_done |= field_widget(fields[i], applied_fields[i]);
      }
      if (!can_rerun) ImGui::BeginDisabled();
      char label[64];
      std::snprintf(label, sizeof label, "Re-run from %s", stage_name(s));
      if (ImGui::Button(label)) app.request_rerun(s);
      if (!can_rerun) ImGui::EndDisabled();
      if (edit_done && state.rerun_on_edit && can_rerun) app.apply_changes();
    }
    ImGui::PopID();
  }
  ImGui::End();
}

void status_panel(ViewerApp& app, PanelState& state, int height) {
  ImGui::SetNextWindowPos(ImVec2(10, 350), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(360, std::max(200.0f, static_cast<float>(height) - 360.0f)), ImGuiCond_FirstUseEver);
  if (!ImGui::Begin("Status", &state.show_status)) {
    ImGui::End();
    return;
  }
  const RunData* run = app.run();
  const JobProgress p = app.progress();
  if (p.running) {
    ImGui::Text("running: %s %.0f%% (%.1f s)", p.phase.c_str(), 100.0 * p.fraction, p.seconds);
  } else if (run) {
    ImGui::Text("ready; last load or re-run took %.2f s", app.last_run_seconds());
  } else {
    ImGui::TextUnformatted("nothing loaded");
  }
  if (!app.error().empty()) {
    ImGui::PushStyleColor(ImGuiCol_Text, kErrorColor);
    ImGui::TextWrapped("error: %s", app.error().c_str());
    ImGui::PopStyleColor();
  }
  if (!run) {
    ImGui::End();
    return;
  }
  ImGui::TextWrapped("%s", run->note.c_str());
  if (ImGui::BeginTable("timings", 2, ImGuiTableFlags_Borders | ImGuiTableFlags_SizingFixedFit)) {
    ImGui::TableSetupColumn("stage");
    ImGui::TableSetupColumn("seconds");
    ImGui::TableHeadersRow();
    double total = 0;
    for (Stage s : kStages) {
      const double sec = run->result.timings.get(stage_name(s));
      total += sec;
      ImGui::TableNextRow();
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(stage_name(s));
      ImGui::TableNextColumn();
      if (run->has_stage(s)) {
        ImGui::Text("%.3f", sec);
      } else {
        ImGui::TextDisabled("-");
      }
    }
    ImGui::TableNextRow();
    ImGui::TableNextColumn();
    ImGui::TextUnformatted("total");
    ImGui::TableNextColumn();
    ImGui::Text("%.3f", total);
    ImGui::EndTable();
  }
  ImGui::Separator();
  ImGui::TextUnformatted("Mesh checks");
  const auto& check = app.check();
  if (!run->has_stage(Stage::meshing)) {
    ImGui::TextDisabled("no mesh");
  } else if (!check) {
    if (p.running && p.kind == JobOutcome::Kind::checks) {
      ImGui::TextDisabled("running...");
    } else if (ImGui::Button("Run checks")) {
      app.request_checks();
    }
  } else {
    const MeshCheckReport& c = *check;
    auto yes_no = [](const char* what, bool ok) {
      ImGui::TextColored(ok ? kOkColor : kErrorColor, "%s: %s", what, ok ? "yes" : "NO");
    };
    yes_no("watertight (closed, manifold, oriented)", c.closed && c.edge_manifold && c.vertex_manifold && c.oriented);
    if (c.genus) {
      ImGui::TextColored(*c.genus == 0 ? kOkColor : kErrorColor, "genus: %lld", static_cast<long long>(*c.genus));
    } else {
      ImGui::TextColored(kErrorColor, "genus: undefined (not a closed oriented manifold)");
    }
    ImGui::Text("components: %zu, degenerate triangles: %zu", c.components, c.degenerate_triangles);
    if (c.self_intersections_checked) {
      ImGui::TextColored(c.self_intersecting_pairs == 0 ? kOkColor : kErrorColor, "self-intersections: %zu pairs",
                         c.self_intersecting_pairs);
    } else {
      ImGui::TextDisabled("self-intersections: not checked");
    }
    if (c.fidelity_checked) {
      ImGui::TextColored(c.fidelity_p95 <= c.fidelity_tolerance ? kOkColor : kErrorColor,
                         "fidelity (distance / radius): p50 %.3f, p95 %.3f, max %.3f", c.fidelity_p50, c.fidelity_p95,
                         c.fidelity_max);
    }
    if (c.inside_checked) ImGui::Text("thick nodes inside: %zu of %zu", c.thick_nodes_inside, c.thick_nodes);
    ImGui::TextColored(c.ok() ? kOkColor : kErrorColor, "result: %s", c.ok() ? "ok" : "FAILED");
    for (const auto& f : c.failures()) ImGui::BulletText("%s", f.c_str());
    if (!c.ok()) ImGui::TextDisabled("the 'problems' layer marks them on the mesh");
  }
  const Warnings w = run->result.warnings();
  if (!w.empty() && ImGui::CollapsingHeader("Warnings")) {
    for (const auto& x : w.list()) {
      std::string line = x.message + " (" + std::to_string(x.count) + "x";
      for (std::size_t i = 0; i < x.examples.size(); ++i) line += (i == 0 ? "; e.g. " : ", ") + x.examples[i];
      line += ")";
      ImGui::BulletText("%s", line.c_str());
    }
  }
  ImGui::End();
}

void node_panel(ViewerApp& app, PanelState& state, PanelActions& actions, int width, int height) {
  if (!app.selection()) return;
  ImGui::SetNextWindowPos(ImVec2(static_cast<float>(width) - 430.0f, 270), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(420, std::max(240.0f, static_cast<float>(height) - 280.0f)), ImGuiCond_FirstUseEver);
  if (!ImGui::Begin("Node", &state.show_node)) {
    ImGui::End();
    return;
  }
  const RunData* run = app.run();
  const NodeCloud* cloud = app.selected_cloud();
  if (!run || !run->has_stage(Stage::skeleton)) {
    ImGui::End();
    return;
  }
  const Skeleton& s = run->result.skeleton.skeleton;
  if (!cloud) {
    ImGui::TextUnformatted(s.describe(*app.selection()).c_str());
    ImGui::Text("radius %.4g m", s.radius[app.selection()->idx()]);
    ImGui::TextDisabled("no particles for this run");
  } else {
    for (const auto& line : node_summary(s, *cloud)) ImGui::TextUnformatted(line.c_str());
  }
  if (ImGui::SmallButton("Frame")) actions.frame_selection = true;
  ImGui::SameLine();
  const NodeId n = *app.selection();
  if (s.parent[n.idx()].valid() && ImGui::SmallButton("Parent")) app.select(s.parent[n.idx()]);
  for (int k = 0; k < 2; ++k) {
    const NodeId c = s.children[n.idx()][k];
    if (!c.valid()) continue;
    ImGui::SameLine();
    if (ImGui::SmallButton(k == 0 ? "Main child" : "Lateral child")) app.select(c);
  }
  ImGui::SameLine();
  if (ImGui::SmallButton("Clear")) app.select(std::nullopt);
  if (!cloud) {
    ImGui::End();
    return;
  }
  cloud = app.selected_cloud();  // the buttons may have changed the selection
  if (!cloud) {
    ImGui::End();
    return;
  }
  ImGui::SetNextItemWidth(120);
  ImGui::SliderFloat("zoom", &state.node_zoom, 0.5f, 4.0f, "%.1fx");
  // The canvas: x along the frame normal (right), y along the binormal (up), like the paper's
  // cross-section figures; the disc of the node radius fills the canvas at zoom 1.
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  const float side = std::max(60.0f, std::min(avail.x, avail.y));
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  ImGui::InvisibleButton("cloud", ImVec2(side, side));
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->AddRectFilled(p0, ImVec2(p0.x + side, p0.y + side), IM_COL32(255, 255, 255, 255));
  const ImVec2 c(p0.x + 0.5f * side, p0.y + 0.5f * side);
  const double r = std::max(cloud->radius, 1e-12);
  const float scale = static_cast<float>(0.46 * static_cast<double>(side) / r) * state.node_zoom;
  auto at = [&](const glm::dvec2& q) {
    return ImVec2(c.x + scale * static_cast<float>(q.x), c.y - scale * static_cast<float>(q.y));
  };
  dl->PushClipRect(p0, ImVec2(p0.x + side, p0.y + side), true);
  dl->AddCircle(c, scale * static_cast<float>(cloud->radius), IM_COL32(120, 90, 60, 255), 96, 1.5f);
  if (cloud->disc_radius > 0) {
    dl->AddCircle(c, scale * static_cast<float>(cloud->disc_radius), IM_COL32(180, 160, 140, 255), 96, 1.0f);
  }
  dl->AddLine(c, ImVec2(c.x + 0.25f * side, c.y), to_imgui(palette::axis_normal), 1.0f);
  dl->AddLine(c, ImVec2(c.x, c.y - 0.25f * side), to_imgui(palette::axis_binormal), 1.0f);
  if (cloud->boundary.size() >= 2) {
    std::vector<ImVec2> loop;
    loop.reserve(cloud->boundary.size());
    for (std::uint32_t i : cloud->boundary) loop.push_back(at(cloud->points[i]));
    dl->AddPolyline(loop.data(), static_cast<int>(loop.size()), IM_COL32(20, 20, 20, 255), ImDrawFlags_Closed, 2.0f);
  }
  const double spacing = run->result.particles.neighbour_distance;
  const float dot = std::clamp(spacing > 0 ? 0.3f * scale * static_cast<float>(spacing) : 3.0f, 1.5f, 12.0f);
  int hovered = -1;
  const ImVec2 mouse = ImGui::GetIO().MousePos;
  for (std::size_t i = 0; i < cloud->points.size(); ++i) {
    const ImVec2 q = at(cloud->points[i]);
    dl->AddCircleFilled(q, dot, to_imgui(cloud->colors[i]), 12);
    const float dx = q.x - mouse.x, dy = q.y - mouse.y;
    if (dx * dx + dy * dy <= (dot + 1) * (dot + 1)) hovered = static_cast<int>(i);
  }
  dl->PopClipRect();
  if (hovered >= 0 && ImGui::IsItemHovered()) {
    const auto& q = cloud->points[static_cast<std::size_t>(hovered)];
    ImGui::SetTooltip("particle %d: strand %u\n(%.4g, %.4g) m", hovered,
                      cloud->strands[static_cast<std::size_t>(hovered)].value, q.x, q.y);
  }
  ImGui::End();
}

}  // namespace

void draw_legend(const ViewerApp& app, float left, int height) {
  const auto entries =
      legend_entries(app.view().visible, app.view().coloring, app.view().shading == MeshShading::uv_checker);
  if (entries.empty()) return;
  ImGui::SetNextWindowPos(ImVec2(left, static_cast<float>(height) - 10.0f), ImGuiCond_Always, ImVec2(0, 1));
  ImGui::SetNextWindowBgAlpha(0.8f);
  const ImGuiWindowFlags flags = ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize |
                                 ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoFocusOnAppearing |
                                 ImGuiWindowFlags_NoNav | ImGuiWindowFlags_NoInputs;
  if (ImGui::Begin("Legend", nullptr, flags)) {
    for (const auto& e : entries) {
      swatch(e.color);
      ImGui::TextUnformatted(e.text.c_str());
    }
  }
  ImGui::End();
}

PanelActions draw_panels(ViewerApp& app, PanelState& state, int width, int height) {
  PanelActions actions;
  if (state.show_main) main_panel(app, state, actions);
  if (state.show_stages) stages_panel(app, state, width);
  if (state.show_status) status_panel(app, state, height);
  if (state.show_node) node_panel(app, state, actions, width, height);
  if (app.view().legend) draw_legend(app, state.show_status ? 380.0f : 10.0f, height);
  if (!state.show_main) {
    // Keep a way back to the main panel.
    ImGui::SetNextWindowPos(ImVec2(10, 10), ImGuiCond_Always);
    if (ImGui::Begin("##reopen", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_AlwaysAutoResize)) {
      if (ImGui::Button("panels")) state.show_main = true;
    }
    ImGui::End();
  }
  return actions;
}

}  // namespace sm::viewer
