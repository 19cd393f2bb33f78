// Parameter files, read and written through each stage's parameter table (core/param_table.h):
// strict keys (an unknown one is named, with the nearest known key), types and ranges checked.

#include <algorithm>
#include <limits>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/file_io.h"
#include "core/input_limits.h"
#include "core/log.h"
#include "core/suggest.h"
#include "pipeline/pipeline.h"

namespace sm {
namespace {

using nlohmann::json;

// Every section's keys, for "did you mean" across sections.
std::vector<std::pair<std::string, std::string>> all_keys();

template <class P>
struct Reader {
  const json& section;
  std::string where;  // "config.json: particles"

  [[noreturn]] void fail(const char* key, const std::string& what, const json& value) const {
    throw InvalidInputError(where + "." + key + ": must be " + what + ", not " + excerpt(value.dump()));
  }

  void read(P& p, const ParamSpec<P>& s, const json& v) const {
    switch (param_kind(s)) {
      case ParamKind::real: {
        double x = 0;
        if (v.is_string() && s.from_name != nullptr) {
          try {
            x = s.from_name(v.get<std::string>());
          } catch (const InvalidInputError& e) {
            throw InvalidInputError(where + "." + s.key + ": " + e.what());
          }
        } else if (v.is_number()) {
          x = v.get<double>();
        } else {
          fail(s.key, "a number", v);
        }
        if (!std::isfinite(x)) throw InvalidInputError(where + "." + s.key + ": must be finite");
        set_param_value(p, s, x);
        return;
      }
      case ParamKind::integer: {
        // (No wrap-around: a value beyond the field's type is an error, not taken modulo 2^32.)
        const std::uint64_t max = param_type_max(s);
        std::uint64_t x = 0;
        if (v.is_number_unsigned() && v.get<std::uint64_t>() <= max) {
          x = v.get<std::uint64_t>();
        } else if (v.is_number_integer() && v.get<std::int64_t>() >= 0 &&
                   static_cast<std::uint64_t>(v.get<std::int64_t>()) <= max) {
          x = static_cast<std::uint64_t>(v.get<std::int64_t>());
        } else {
          fail(s.key, "a non-negative integer up to " + std::to_string(max), v);
        }
        set_integer(p, s, x);
        return;
      }
      case ParamKind::flag:
        if (!v.is_boolean()) fail(s.key, "true or false", v);
        set_param_value(p, s, v.get<bool>() ? 1.0 : 0.0);
        return;
      case ParamKind::choice: {
        const auto& names = std::get<ParamChoice<P>>(s.field).names;
        for (std::size_t i = 0; i < names.size() && v.is_string(); ++i) {
          if (v.get<std::string>() == names[i]) return set_param_value(p, s, double(i));
        }
        std::string list;
        for (std::size_t i = 0; i < names.size(); ++i) {
          list += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + std::string("\"") + names[i] + "\"";
        }
        fail(s.key, list, v);
      }
      case ParamKind::text: {
        const auto& text = std::get<ParamText<P>>(s.field);
        if (!v.is_string()) {
          std::string accepted = text.accepted;
          std::erase(accepted, '`');
          fail(s.key, "a string: " + accepted, v);
        }
        try {
          text.set(p, v.get<std::string>());
        } catch (const InvalidInputError& e) {
          throw InvalidInputError(where + "." + s.key + ": " + e.what());
        }
        return;
      }
    }
  }

  // Integers are set exactly (a seed above 2^53 must survive the round trip).
  static void set_integer(P& p, const ParamSpec<P>& s, std::uint64_t x) {
    std::visit(
        [&p, x]<class M>(M m) {
          if constexpr (std::is_member_object_pointer_v<M>) {
            using T = std::remove_cvref_t<decltype(p.*m)>;
            if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) p.*m = static_cast<T>(x);
          }
        },
        s.field);
  }

  void operator()(P& p) const {
    const auto& fields = param_table_of<P>().fields;
    for (const ParamSpec<P>& s : fields) {
      if (auto it = section.find(s.key); it != section.end()) read(p, s, *it);
    }
    for (auto it = section.begin(); it != section.end(); ++it) {
      const bool known = std::any_of(fields.begin(), fields.end(), [&](const auto& s) { return it.key() == s.key; });
      if (!known) throw InvalidInputError(where + ": unknown key \"" + excerpt(it.key()) + "\"" + suggestion(it.key()));
    }
  }

  // " (did you mean "seed"?)", or the section a key belongs to, or the list of known keys.
  [[nodiscard]] std::string suggestion(const std::string& key) const {
    const char* own = param_table_of<P>().section;
    std::vector<std::string> mine;
    for (const auto& s : param_table_of<P>().fields) mine.emplace_back(s.key);
    if (const std::string near = closest_name(key, mine); !near.empty()) return " (did you mean \"" + near + "\"?)";
    for (const auto& [section_name, k] : all_keys()) {
      if (section_name != own && k == key) return " (it belongs in section \"" + section_name + "\")";
    }
    std::string list;
    for (const auto& k : mine) list += (list.empty() ? "" : ", ") + k;
    return " (known keys: " + list + ")";
  }
};

template <class P>
json write_section(const P& p) {
  json j = json::object();
  for (const ParamSpec<P>& s : param_table_of<P>().fields) {
    std::visit(
        [&]<class M>(M m) {
          if constexpr (std::is_same_v<M, ParamChoice<P>>) {
            j[s.key] = m.names[static_cast<std::size_t>(m.get(p))];
          } else if constexpr (std::is_same_v<M, ParamText<P>>) {
            j[s.key] = m.get(p);
          } else {
            j[s.key] = p.*m;
          }
        },
        s.field);
  }
  return j;
}

template <class P>
void add_keys(std::vector<std::pair<std::string, std::string>>& out) {
  for (const auto& s : param_table_of<P>().fields) out.emplace_back(param_table_of<P>().section, s.key);
}

std::vector<std::pair<std::string, std::string>> all_keys() {
  std::vector<std::pair<std::string, std::string>> out;
  const PipelineParams defaults;
  for_each_config_section(defaults, [&out]<class P>(const P&) { add_keys<P>(out); });
  return out;
}

// Keys that moved into P's section from another (ParamTable::moved) are read as their new
// key, with a deprecation warning; where the new key is given too, it wins.
template <class P>
void move_renamed_keys(json& doc, const std::string& file) {
  const ParamTable<P>& t = param_table_of<P>();
  for (const ParamMoved& m : t.moved) {
    const auto from = doc.find(m.section);
    if (from == doc.end() || !from->is_object() || !from->contains(m.key)) continue;
    if (!doc.contains(t.section)) doc[t.section] = json::object();
    json& to = doc[t.section];
    if (!to.is_object()) return;  // (read_section names the error)
    const std::string old_key = std::string(m.section) + "." + m.key, new_key = std::string(t.section) + "." + m.now;
    if (to.contains(m.now)) {
      log::warn(file + ": " + old_key + " is ignored: it is now " + new_key + ", which is given too");
    } else {
      log::warn(file + ": " + old_key + " is now " + new_key + " (read as that; the old key will go)");
      to[m.now] = (*from)[m.key];
    }
    from->erase(m.key);
  }
}

template <class P>
void read_section(const json& doc, const std::string& file, P& params) {
  const char* name = param_table_of<P>().section;
  auto it = doc.find(name);
  if (it == doc.end()) return;
  if (!it->is_object()) throw InvalidInputError(file + ": \"" + name + "\" must be an object");
  Reader<P>{*it, file + ": " + name}(params);
}

}  // namespace

PipelineParams parse_params_json(std::string_view text, const std::string& name, const PipelineParams& base) {
  check_json_nesting(text, name);
  json doc;
  try {
    doc = json::parse(text.begin(), text.end());
  } catch (const json::exception& e) {
    // A parse error names its line and column in `what`; a number overflow (out_of_range.406) does not.
    std::string what = e.what();
    const auto bracket = what.find("] ");
    const std::string place = e.id == 406 ? json_error_line_col(text) : "";
    throw InvalidInputError(name + (place.empty() ? "" : ":" + place) + ": not valid JSON: " +
                            (bracket != std::string::npos ? what.substr(bracket + 2) : what));
  }
  if (!doc.is_object()) throw InvalidInputError(name + ": a config file must be a JSON object");
  std::vector<std::string> sections;
  const PipelineParams defaults;
  for_each_config_section(defaults,
                          [&sections]<class P>(const P&) { sections.emplace_back(param_table_of<P>().section); });
  for (const char* other : {"description", "comment"}) sections.emplace_back(other);
  for (auto it = doc.begin(); it != doc.end(); ++it) {
    if (std::find(sections.begin(), sections.end(), it.key()) == sections.end()) {
      const std::string near = closest_name(it.key(), sections);
      std::string known;
      for (const auto& k : sections) known += (known.empty() ? "" : ", ") + k;
      throw InvalidInputError(name + ": unknown section \"" + excerpt(it.key()) + "\"" +
                              (near.empty() ? "" : " (did you mean \"" + near + "\"?)") + " (known: " + known + ")");
    }
  }
  PipelineParams p = base;
  for_each_config_section(p, [&]<class P>(P&) { move_renamed_keys<P>(doc, name); });
  for_each_config_section(p, [&]<class P>(P& section) { read_section(doc, name, section); });
  // Values out of range, named with the file (the stages check them again).
  try {
    for_each_config_section(p, []<class P>(const P& section) { check_params(section); });
  } catch (const InvalidInputError& e) {
    throw InvalidInputError(name + ": " + e.what());
  }
  return p;
}

PipelineParams load_params(const std::filesystem::path& path, const PipelineParams& base) {
  return parse_params_json(read_file(path), path.string(), base);
}

std::string params_to_json(const PipelineParams& p) {
  json doc;
  for_each_config_section(p,
                          [&doc]<class P>(const P& section) { doc[param_table_of<P>().section] = write_section(section); });
  return doc.dump(2) + "\n";
}

namespace {

template <class P>
std::string accepted(const ParamSpec<P>& s) {
  switch (param_kind(s)) {
    case ParamKind::flag:
      return "true, false";
    case ParamKind::choice: {
      std::string list;
      for (const char* n : std::get<ParamChoice<P>>(s.field).names) list += (list.empty() ? "`" : ", `") + std::string(n) + "`";
      return list;
    }
    case ParamKind::text:
      return std::get<ParamText<P>>(s.field).accepted;
    default:
      return s.range.rule();
  }
}

template <class P>
void reference_section(std::string& out, const P& defaults, bool markdown) {
  const ParamTable<P>& t = param_table_of<P>();
  const json values = write_section(defaults);
  if (!markdown) {
    for (const ParamSpec<P>& s : t.fields) {
      std::string rule = accepted(s);
      std::erase(rule, '`');
      out += std::string(t.section) + "." + s.key + " = " + values.at(s.key).dump() + "  (" + rule +
             (*s.unit ? std::string("; ") + s.unit : "") + ")\n    " + s.help + "\n";
    }
    return;
  }
  out += "\n### " + std::string(t.section) + "\n\n";
  out += "| key | default | accepted | unit | meaning |\n|---|---|---|---|---|\n";
  for (const ParamSpec<P>& s : t.fields) {
    out += "| `" + std::string(s.key) + "` | " + values.at(s.key).dump() + " | " + accepted(s) + " | " + s.unit + " | " +
           s.help + " |\n";
  }
  if (t.moved.empty()) return;
  out += "\nKeys that moved here (still read, with a warning):";
  for (std::size_t i = 0; i < t.moved.size(); ++i) {
    const ParamMoved& m = t.moved[i];
    out += std::string(i == 0 ? " " : ", ") + "`" + m.section + "." + m.key + "` as `" + m.now + "`";
  }
  out += ".\n";
}

}  // namespace

std::string params_reference(bool markdown) {
  if (!markdown) {
    std::string out;
    const PipelineParams defaults;
    for_each_config_section(defaults, [&out]<class P>(const P& p) { reference_section(out, p, false); });
    return out;
  }
  std::string out =
      "Every key of a config file, by section, with its default (the initializer in the stage's\n"
      "Params header), the values accepted and the unit (\"x local radius\": relative to the\n"
      "branch radius there; lambda: the particle spacing in a cross-section). The `export`\n"
      "section, how the mesh is written, is described further in [export.md](export.md).\n";
  const PipelineParams defaults;
  for_each_config_section(defaults, [&out]<class P>(const P& p) { reference_section(out, p, true); });
  return out;
}

}  // namespace sm
