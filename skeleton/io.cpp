#include "skeleton/io.h"

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <string>

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/file_io.h"
#include "core/input_limits.h"

namespace sm {
namespace {

using nlohmann::json;

/// Line and column (1-based) of byte offset `pos` in `text`.
std::pair<std::size_t, std::size_t> line_col(std::string_view text, std::size_t pos) {
  std::size_t line = 1, col = 1;
  for (std::size_t i = 0; i < pos && i < text.size(); ++i) {
    if (text[i] == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  }
  return {line, col};
}

const char* type_name(const json& j) {
  return j.type_name();
}

std::int64_t get_int(const json& node, const char* key, const std::string& where) {
  auto it = node.find(key);
  if (it == node.end()) throw InvalidInputError(where + ": missing \"" + key + "\"");
  if (it->is_number_integer()) return it->get<std::int64_t>();
  if (it->is_number_unsigned()) {
    const auto u = it->get<std::uint64_t>();
    if (u > static_cast<std::uint64_t>(INT64_MAX)) throw InvalidInputError(where + ": \"" + key + "\" is too large");
    return static_cast<std::int64_t>(u);
  }
  if (it->is_number_float()) {
    const double d = it->get<double>();
    if (std::isfinite(d) && d == std::floor(d) && std::abs(d) < 9e15) return static_cast<std::int64_t>(d);
  }
  throw InvalidInputError(where + ": \"" + key + "\" must be an integer, not " + type_name(*it) +
                          (it->is_primitive() ? " " + excerpt(it->dump()) : std::string()));
}

double get_number(const json& j, const std::string& what, const std::string& where) {
  if (!j.is_number()) {
    throw InvalidInputError(where + ": " + what + " must be a number, not " + type_name(j) +
                            (j.is_primitive() ? " " + excerpt(j.dump()) : std::string()));
  }
  return j.get<double>();
}

UpAxis parse_up_axis(const json& doc, const std::string& name) {
  auto it = doc.find("up_axis");
  if (it == doc.end()) return UpAxis::z;
  if (it->is_string()) {
    const auto s = it->get<std::string>();
    if (s == "z" || s == "Z") return UpAxis::z;
    if (s == "y" || s == "Y") return UpAxis::y;
  }
  throw InvalidInputError(name + ": \"up_axis\" must be \"z\" or \"y\", not " + excerpt(it->dump()));
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

bool parse_double(std::string_view tok, double& out) {
  // strtod accepts "nan"/"inf", which validation then rejects with a clear message.
  std::string s(tok);
  char* end = nullptr;
  out = std::strtod(s.c_str(), &end);
  return end == s.c_str() + s.size() && !s.empty();
}

bool parse_int(std::string_view tok, std::int64_t& out) {
  auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  if (ec == std::errc() && p == tok.data() + tok.size()) return true;
  double d = 0;  // some SWC writers print ids as floats ("12.0")
  if (parse_double(tok, d) && std::isfinite(d) && d == std::floor(d) && std::abs(d) < 9e15) {
    out = static_cast<std::int64_t>(d);
    return true;
  }
  return false;
}

}  // namespace

RawSkeleton parse_skeleton_json(std::string_view text, const std::string& name) {
  if (trim(text).empty()) throw InvalidInputError(name + ": the file is empty");
  check_json_nesting(text, name);
  json doc;
  try {
    doc = json::parse(text.begin(), text.end());
  } catch (const json::parse_error& e) {
    const auto [line, col] = line_col(text, e.byte > 0 ? e.byte - 1 : 0);
    std::string what = e.what();
    // nlohmann's message: "[json.exception.parse_error.101] parse error at line 1, column 5: ..."
    const auto colon = what.find(": ", what.find("parse error"));
    const std::string detail = colon != std::string::npos ? what.substr(colon + 2) : what;
    throw InvalidInputError(name + ":" + std::to_string(line) + ":" + std::to_string(col) +
                            ": not valid JSON: " + detail);
  } catch (const json::exception& e) {
    // e.g. out_of_range.406 "number overflow parsing '1e999'", which carries no position:
    // find it, and strip the library prefix.
    std::string what = e.what();
    const auto bracket = what.find("] ");
    const std::string place = json_error_line_col(text);
    throw InvalidInputError(name + (place.empty() ? "" : ":" + place) +
                            ": not valid JSON: " + (bracket != std::string::npos ? what.substr(bracket + 2) : what));
  }
  if (!doc.is_object()) throw InvalidInputError(name + ": the top level must be an object with a \"nodes\" array");
  auto nodes = doc.find("nodes");
  if (nodes == doc.end()) throw InvalidInputError(name + ": missing the \"nodes\" array");
  if (!nodes->is_array()) throw InvalidInputError(name + ": \"nodes\" must be an array, not " + nodes->type_name());

  RawSkeleton raw;
  raw.source = name;
  raw.up_axis = parse_up_axis(doc, name);
  if (const auto it = doc.find("grown"); it != doc.end() && it->is_boolean()) raw.grown = it->get<bool>();
  if (const auto it = doc.find("sanitized"); it != doc.end()) {
    if (!it->is_boolean()) throw InvalidInputError(name + ": \"sanitized\" must be true or false, not " + excerpt(it->dump()));
    raw.sanitized = it->get<bool>();
  }
  const std::size_t n = nodes->size();
  raw.id.reserve(n);
  raw.parent_id.reserve(n);
  raw.position.reserve(n);
  raw.radius.reserve(n);
  raw.where.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    const json& node = (*nodes)[k];
    std::string where = name + ": nodes[" + std::to_string(k) + "]";
    if (!node.is_object()) throw InvalidInputError(where + ": must be an object, not " + node.type_name());
    const std::int64_t id = get_int(node, "id", where);
    where += " (id " + std::to_string(id) + ")";
    const std::int64_t parent = get_int(node, "parent", where);
    auto pos = node.find("position");
    if (pos == node.end()) throw InvalidInputError(where + ": missing \"position\"");
    if (!pos->is_array() || pos->size() != 3) {
      throw InvalidInputError(where + ": \"position\" must be an array of 3 numbers");
    }
    dvec3 p;
    for (int a = 0; a < 3; ++a)
      p[a] = get_number((*pos)[std::size_t(a)], "\"position\"[" + std::to_string(a) + "]", where);
    auto rad = node.find("radius");
    if (rad == node.end()) throw InvalidInputError(where + ": missing \"radius\"");
    const double r = get_number(*rad, "\"radius\"", where);
    if (const auto base = node.find("base_radius"); base != node.end()) {
      const double b = get_number(*base, "\"base_radius\"", where);
      if (!(b >= 0)) throw InvalidInputError(where + ": \"base_radius\" must be >= 0, got " + excerpt(base->dump()));
      raw.base_radius.resize(n, 0.0);
      raw.base_radius[k] = b;
    }
    raw.id.push_back(id);
    raw.parent_id.push_back(parent);
    raw.position.push_back(p);
    raw.radius.push_back(r);
    raw.where.push_back("nodes[" + std::to_string(k) + "] (id " + std::to_string(id) + ")");
  }
  return raw;
}

RawSkeleton parse_swc(std::string_view text, const std::string& name) {
  if (trim(text).empty()) throw InvalidInputError(name + ": the file is empty");
  RawSkeleton raw;
  raw.source = name;
  raw.up_axis = UpAxis::z;
  std::size_t line_no = 0;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(start, end - start);
    ++line_no;
    start = end + 1;
    if (const auto hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    line = trim(line);
    if (line.empty()) {
      if (end == text.size()) break;
      continue;
    }
    const std::string where = name + ":" + std::to_string(line_no);
    std::string_view tok[8];
    int count = 0;
    std::size_t i = 0;
    while (i < line.size()) {
      while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == ',')) ++i;
      if (i >= line.size()) break;
      std::size_t j = i;
      while (j < line.size() && line[j] != ' ' && line[j] != '\t' && line[j] != ',') ++j;
      if (count < 8) tok[count] = line.substr(i, j - i);
      ++count;
      i = j;
    }
    if (count != 7) {
      throw InvalidInputError(where + ": expected 7 fields (id type x y z radius parent), found " +
                              std::to_string(count));
    }
    if (line.find_first_of("\x01\x02\x03\x04\x05\x06\x07\x08\x0e\x0f") != std::string_view::npos) {
      throw InvalidInputError(where + ": binary data, not an SWC text line");
    }
    std::int64_t id = 0, parent = 0, type = 0;
    double v[4];
    if (!parse_int(tok[0], id))
      throw InvalidInputError(where + ": id \"" + excerpt(tok[0]) + "\" is not an integer");
    if (!parse_int(tok[1], type))
      throw InvalidInputError(where + ": type \"" + excerpt(tok[1]) + "\" is not an integer");
    static const char* names[4] = {"x", "y", "z", "radius"};
    for (int a = 0; a < 4; ++a) {
      if (!parse_double(tok[2 + a], v[a])) {
        throw InvalidInputError(where + ": " + names[a] + " \"" + excerpt(tok[2 + a]) + "\" is not a number");
      }
    }
    if (!parse_int(tok[6], parent)) {
      throw InvalidInputError(where + ": parent \"" + excerpt(tok[6]) + "\" is not an integer");
    }
    // SWC marks the root with any negative parent (usually -1).
    if (parent < 0) parent = -1;
    raw.id.push_back(id);
    raw.parent_id.push_back(parent);
    raw.position.emplace_back(v[0], v[1], v[2]);
    raw.radius.push_back(v[3]);
    raw.where.push_back("line " + std::to_string(line_no) + " (id " + std::to_string(id) + ")");
    if (end == text.size()) break;
  }
  return raw;
}

std::string skeleton_to_json(const Skeleton& s, const std::string& source) {
  json doc;
  doc["source"] = source.empty() ? std::string("strandmesh") : source;
  doc["up_axis"] = s.up_axis == UpAxis::y ? "y" : "z";
  doc["units"] = "m";
  doc["sanitized"] = true;  // see RawSkeleton::sanitized
  json nodes = json::array();
  for (std::size_t i = 0; i < s.size(); ++i) {
    json node;
    node["id"] = i;
    node["parent"] = s.parent[i].valid() ? static_cast<std::int64_t>(s.parent[i].value) : -1;
    node["position"] = {s.position[i].x, s.position[i].y, s.position[i].z};
    node["radius"] = s.radius[i];
    if (s.source_id[i] >= 0) node["source_id"] = s.source_id[i];
    if (i < s.base_radius.size() && s.base_radius[i] > 0) node["base_radius"] = s.base_radius[i];
    nodes.push_back(std::move(node));
  }
  doc["nodes"] = std::move(nodes);
  return doc.dump() + "\n";
}

std::string raw_skeleton_to_json(const RawSkeleton& raw) {
  json doc;
  doc["source"] = raw.source.empty() ? std::string("strandmesh") : raw.source;
  doc["up_axis"] = raw.up_axis == UpAxis::y ? "y" : "z";
  doc["units"] = "m";
  if (raw.grown) doc["grown"] = true;  // see RawSkeleton::grown
  json nodes = json::array();
  for (std::size_t i = 0; i < raw.size(); ++i) {
    nodes.push_back({{"id", raw.id[i]},
                     {"parent", raw.parent_id[i]},
                     {"position", {raw.position[i].x, raw.position[i].y, raw.position[i].z}},
                     {"radius", raw.radius[i]}});
    if (i < raw.base_radius.size() && raw.base_radius[i] > 0) nodes.back()["base_radius"] = raw.base_radius[i];
  }
  doc["nodes"] = std::move(nodes);
  return doc.dump() + "\n";
}

void write_skeleton_json(const Skeleton& s, const std::filesystem::path& path, const std::string& source) {
  write_file_atomically(path, skeleton_to_json(s, source));
}

}  // namespace sm
