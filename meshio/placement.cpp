// The placement record of written meshes (see placement.h).

#include "meshio/placement.h"

#include <charconv>
#include <cmath>
#include <vector>

namespace sm {

namespace {

std::string shortest(double x) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, x);  // shortest text that round-trips
  return std::string(buf, r.ptr);
}

bool parse_double(std::string_view s, double& x) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), x);
  return r.ec == std::errc() && r.ptr == s.data() + s.size() && std::isfinite(x);
}

}  // namespace

std::string placement_comment(const Placement& p) {
  const glm::dvec3 t = p.translation() + glm::dvec3(0.0);  // -0 prints as 0
  return std::string("strandmesh-placement up ") + (p.to == UpAxis::y ? "y" : "z") + " scale " + shortest(p.scale) +
         " translation " + shortest(t.x) + " " + shortest(t.y) + " " + shortest(t.z);
}

std::optional<FilePlacement> find_placement_comment(std::string_view bytes, std::size_t head) {
  const std::string_view text = bytes.substr(0, std::min(head, bytes.size()));
  constexpr std::string_view kKey = "strandmesh-placement ";
  const std::size_t at = text.find(kKey);
  if (at == std::string_view::npos) return std::nullopt;
  std::string_view line = text.substr(at + kKey.size());
  line = line.substr(0, line.find_first_of("\r\n"));
  std::vector<std::string_view> tok;
  for (std::size_t i = 0; i < line.size();) {
    const std::size_t j = std::min(line.find(' ', i), line.size());
    if (j > i) tok.push_back(line.substr(i, j - i));
    i = j + 1;
  }
  FilePlacement fp;
  if (tok.size() != 8 || tok[0] != "up" || tok[2] != "scale" || tok[4] != "translation") return std::nullopt;
  if (tok[1] != "y" && tok[1] != "z") return std::nullopt;
  fp.up = tok[1] == "y" ? UpAxis::y : UpAxis::z;
  if (!parse_double(tok[3], fp.scale) || !(fp.scale > 0)) return std::nullopt;
  for (int k = 0; k < 3; ++k) {
    if (!parse_double(tok[5 + static_cast<std::size_t>(k)], fp.translation[k])) return std::nullopt;
  }
  return fp;
}

}  // namespace sm
