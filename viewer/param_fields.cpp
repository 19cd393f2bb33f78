// The stage panels' fields, built from the stage parameter tables (core/param_table.h).

#include "viewer/param_fields.h"

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

namespace sm::viewer {

namespace {

template <class P>
void add_fields(std::vector<ParamField>& out, P& params, const std::string& prefix = "") {
  for (const ParamSpec<P>& s : param_table_of<P>().fields) {
    ParamField f;
    f.key = prefix + s.key;
    f.kind = param_kind(s);
    f.help = s.help;
    if (*s.unit) f.help += std::string(" (") + s.unit + ")";
    if (f.kind == ParamKind::real || f.kind == ParamKind::integer) f.help += "; accepted: " + s.range.rule();
    if (f.kind == ParamKind::choice) {
      for (const char* n : std::get<ParamChoice<P>>(s.field).names) f.choices.emplace_back(n);
    }
    if (s.slider.lo != s.slider.hi) {
      f.min = s.slider.lo;
      f.max = s.slider.hi;
      f.logarithmic = s.slider.logarithmic;
    } else if (f.kind == ParamKind::choice) {
      f.min = 0;
      f.max = static_cast<double>(f.choices.size()) - 1;
    } else if (std::isfinite(s.range.min) && std::isfinite(s.range.max)) {
      f.min = s.range.min;
      f.max = s.range.max;
    }
    const ParamSpec<P>* spec = &s;  // tables are static: the pointer stays valid
    f.get = [&params, spec] { return param_value(params, *spec); };
    f.set = [&params, spec](double v) { set_param_value(params, *spec, v); };
    out.push_back(std::move(f));
  }
}

}  // namespace

std::vector<ParamField> param_fields(PipelineParams& params, Stage stage) {
  std::vector<ParamField> out;
  switch (stage) {
    case Stage::skeleton:
      add_fields(out, params.skeleton);
      break;
    case Stage::particles:
      add_fields(out, params.particles);
      break;
    case Stage::strands:
      add_fields(out, params.strands);
      break;
    case Stage::contours:
      add_fields(out, params.contours);
      break;
    case Stage::meshing:
      add_fields(out, params.meshing);
      add_fields(out, params.repair, "repair.");
      break;
  }
  return out;
}

double field_value(const ParamField& f) { return f.get ? f.get() : 0.0; }

void set_field_value(const ParamField& f, double v) {
  if (f.set) f.set(v);
}

std::optional<Stage> first_changed_stage(const PipelineParams& a, const PipelineParams& b) {
  // Compared in the config-file form: every table field, integers exactly.
  const auto ja = nlohmann::json::parse(params_to_json(a));
  const auto jb = nlohmann::json::parse(params_to_json(b));
  for (Stage s : kStages) {
    if (ja.at(stage_name(s)) != jb.at(stage_name(s))) return s;
    if (s == Stage::meshing && ja.at("repair") != jb.at("repair")) return s;
  }
  return std::nullopt;
}

}  // namespace sm::viewer
