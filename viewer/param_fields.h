#pragma once
/// The viewer's description of every stage's Params: one `ParamField` per field, pointing into
/// a PipelineParams, with the help text and a sensible slider range. The Params structs carry
/// no UI (docs/codingstyle.md); this table is the viewer's side of that contract, and the stage
/// panels (viewer/panels.h) draw it generically. Tests check that the table covers every key
/// of each section of params_to_json.

#include <cstdint>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "pipeline/pipeline.h"

namespace sm::viewer {

/// A std::size_t field (a distinct type so that the variant below stays valid on platforms
/// where std::size_t and std::uint64_t are the same type).
struct SizeRef {
  std::size_t* p = nullptr;
};

/// A parameter the table below does not know by type (a field added to a Params struct after
/// the viewer's table was written): read and written through the config-file form
/// (params_to_json / parse_params_json), so every key of the config file is editable.
struct ConfigRef {
  PipelineParams* params = nullptr;
  Stage stage = Stage::skeleton;
};

/// One editable parameter.
struct ParamField {
  std::string key;   ///< the field name, as in the config file
  std::string help;  ///< one line: meaning and unit
  std::variant<double*, std::uint32_t*, std::uint64_t*, SizeRef, bool*, ThickChildPolicy*, ConfigRef> value;
  double min = 0;  ///< slider range (numbers); values outside can still be typed
  double max = 1;
  bool logarithmic = false;  ///< slider in log scale (ranges spanning decades)
};

/// The fields of one stage's Params inside `params` (pointers into it): the typed table in
/// header order, then a ConfigRef field for every key of that stage's section of
/// params_to_json that the table lacks.
std::vector<ParamField> param_fields(PipelineParams& params, Stage stage);

/// What a ConfigRef field holds in the config file: a number, a bool or a string.
enum class ConfigKind { number, integer, boolean, text };
ConfigKind config_kind(const ParamField& f);

/// The value of a field as a number (bools 0/1, enums their index, text 0); for tests and
/// display.
double field_value(const ParamField& f);
/// Sets a field from a number (rounded for integers, clamped to the type's range).
/// Throws InvalidInputError when a ConfigRef value is out of its accepted range.
void set_field_value(const ParamField& f, double v);

/// The earliest stage whose parameters differ between `a` and `b`, or std::nullopt when they
/// are equal. Re-running from there updates everything that depends on the change.
std::optional<Stage> first_changed_stage(const PipelineParams& a, const PipelineParams& b);

/// All stages in order.
inline constexpr Stage kStages[] = {Stage::skeleton, Stage::particles, Stage::strands, Stage::contours, Stage::meshing};

}  // namespace sm::viewer
