#pragma once
/// The viewer's view of every stage's Params: one `ParamField` per row of the stage's
/// parameter table (core/param_table.h), pointing into a PipelineParams. Key, help, unit,
/// accepted range and slider come from that table; the Params structs carry no UI
/// (docs/codingstyle.md), and the stage panels (viewer/panels.h) draw these fields generically.

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "core/param_table.h"
#include "pipeline/pipeline.h"

namespace sm::viewer {

/// One editable parameter.
struct ParamField {
  std::string key;   ///< the config key ("repair.<key>" for the repair fields of the meshing panel)
  std::string help;  ///< one line: meaning, unit and accepted values
  ParamKind kind = ParamKind::real;
  std::vector<std::string> choices;  ///< the names of a choice's values, by index
  double min = 0;                    ///< slider range (numbers); values outside can still be typed
  double max = 1;
  bool logarithmic = false;  ///< slider in log scale (ranges spanning decades)
  std::function<double()> get;          ///< the value as a number (flags 0/1, choices their index)
  std::function<void(double)> set;      ///< sets it (rounded and clamped for integers and choices)
};

/// The fields of one stage's Params inside `params` (pointing into it), in table order; the
/// meshing stage's panel also holds the repair stage's fields (a re-run from meshing runs it).
std::vector<ParamField> param_fields(PipelineParams& params, Stage stage);

/// The value of a field as a number (bools 0/1, enums their index); for tests and display.
double field_value(const ParamField& f);
/// Sets a field from a number (rounded for integers, clamped to the type's range).
void set_field_value(const ParamField& f, double v);

/// The earliest stage whose parameters differ between `a` and `b`, or std::nullopt when they
/// are equal. Re-running from there updates everything that depends on the change.
std::optional<Stage> first_changed_stage(const PipelineParams& a, const PipelineParams& b);

/// All stages in order.
inline constexpr Stage kStages[] = {Stage::skeleton, Stage::particles, Stage::strands, Stage::contours, Stage::meshing};

}  // namespace sm::viewer
