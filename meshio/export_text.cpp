// The names of ExportParams' values, for the CLI and config files (see export_text.h).

#include "meshio/export_text.h"

#include <charconv>
#include <cmath>
#include <functional>
#include <set>
#include <vector>

#include "core/errors.h"
#include "core/suggest.h"

namespace sm {

namespace {

// One optional vertex attribute: its name on the command line and in config files, and its switch.
struct AttributeName {
  const char* name;
  bool ExportParams::*flag;
};
const std::vector<AttributeName>& attribute_names() {
  static const std::vector<AttributeName> names{
      {"normal", &ExportParams::normals},
      {"uv", &ExportParams::uvs},
      {"branch_id", &ExportParams::branch_ids},
      {"level", &ExportParams::branch_level},
      {"root_distance", &ExportParams::root_distance},
      {"pivot", &ExportParams::branch_pivot},
      {"direction", &ExportParams::branch_direction},
      {"phase", &ExportParams::branch_phase},
      {"thickness", &ExportParams::thickness},
      {"color", &ExportParams::color},
      {"uv1", &ExportParams::uv1},
      {"tangent", &ExportParams::tangents},
  };
  return names;
}

std::vector<std::string> names_of(const std::vector<AttributeName>& a) {
  std::vector<std::string> out;
  for (const auto& n : a) out.emplace_back(n.name);
  return out;
}

std::string join(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) {
    if (!out.empty()) out += ", ";
    out += n;
  }
  return out;
}

std::string hint(std::string_view word, const std::vector<std::string>& names) {
  const std::string best = closest_name(word, names);
  return best.empty() ? std::string() : " (did you mean \"" + best + "\"?)";
}

}  // namespace

std::optional<UpAxis> parse_up_axis(std::string_view text) {
  if (text == "y") return UpAxis::y;
  if (text == "z") return UpAxis::z;
  if (text == "auto") return std::nullopt;
  throw InvalidInputError("up axis must be y, z or auto, not \"" + std::string(text) + "\"");
}

std::optional<Pivot> parse_pivot(std::string_view text) {
  if (text == "root") return Pivot::root;
  if (text == "center" || text == "centre") return Pivot::center;
  if (text == "origin") return Pivot::origin;
  if (text == "auto") return std::nullopt;
  throw InvalidInputError("pivot must be root, center, origin or auto, not \"" + std::string(text) + "\"");
}

Compression parse_compression(std::string_view text) {
  if (text == "meshopt") return Compression::meshopt;
  if (text == "none") return Compression::none;
  throw InvalidInputError("compression must be meshopt or none, not \"" + std::string(text) + "\"");
}

double parse_scale(std::string_view text) {
  if (text == "m") return 1.0;
  if (text == "cm") return 100.0;
  if (text == "mm") return 1000.0;
  if (text == "in") return 1.0 / 0.0254;
  if (text == "ft") return 1.0 / 0.3048;
  double x = 0;
  const auto r = std::from_chars(text.data(), text.data() + text.size(), x);
  if (r.ec != std::errc() || r.ptr != text.data() + text.size() || !(x > 0) || !std::isfinite(x)) {
    throw InvalidInputError("scale must be a positive number of file units per metre or one of m, cm, mm, in, ft, "
                            "not \"" + std::string(text) + "\"");
  }
  return x;
}

void set_attributes(std::string_view list, ExportParams& params) {
  const auto& table = attribute_names();
  std::vector<std::string> words;
  for (std::size_t i = 0; i <= list.size();) {
    const std::size_t j = std::min(list.find(',', i), list.size());
    std::string w(list.substr(i, j - i));
    while (!w.empty() && w.front() == ' ') w.erase(w.begin());
    while (!w.empty() && w.back() == ' ') w.pop_back();
    if (!w.empty()) words.push_back(w);
    i = j + 1;
  }
  for (const auto& a : table) params.*(a.flag) = false;
  std::vector<std::string> accepted = names_of(table);
  accepted.insert(accepted.end(), {"wind", "all", "none"});
  for (const std::string& w : words) {
    if (w == "none") continue;
    bool found = false;
    for (const auto& a : table) {
      static const std::set<std::string> wind{"level", "root_distance", "pivot", "direction", "phase", "thickness"};
      if (w == a.name || w == "all" || (w == "wind" && wind.count(a.name))) {
        params.*(a.flag) = true;
        found = true;
      }
    }
    if (!found) {
      throw InvalidInputError("unknown attribute \"" + w + "\"" + hint(w, accepted) + "; accepted: " + join(accepted));
    }
  }
}

std::string attribute_list(const ExportParams& params) {
  std::string out;
  for (const auto& a : attribute_names()) {
    if (!(params.*(a.flag))) continue;
    if (!out.empty()) out += ',';
    out += a.name;
  }
  return out.empty() ? "none" : out;
}

}  // namespace sm
