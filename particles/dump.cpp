// JSON dump of particle fields (format in dump.h). nlohmann-json writes doubles in their
// shortest round-trip form, so a dump read back gives the same bits.

#include "particles/dump.h"

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/input_limits.h"

namespace sm {
namespace {

nlohmann::json warnings_json(const Warnings& w) {
  nlohmann::json out = nlohmann::json::array();
  for (const Warning& x : w.list()) {
    out.push_back({{"kind", x.kind}, {"message", x.message}, {"count", x.count}, {"examples", x.examples}});
  }
  return out;
}

template <class T>
std::vector<T> get_vector(const nlohmann::json& j, const char* key) {
  if (!j.contains(key) || !j[key].is_array()) {
    throw InvalidInputError(std::string("particles dump: missing array \"") + key + "\"");
  }
  return j[key].get<std::vector<T>>();
}

}  // namespace

std::string particles_to_json(const Skeleton& skeleton, const ParticleField& f) {
  SM_CHECK(f.node_count() == skeleton.size(), "particles_to_json: field and skeleton differ in node count");
  nlohmann::json j;
  j["format"] = "strandmesh-particles";
  j["version"] = 1;
  j["spacing"] = f.spacing;
  j["neighbour_distance"] = f.neighbour_distance;
  j["nodes"] = f.node_count();
  j["particles"] = f.position.size();
  j["strands"] = f.strand_count();
  j["node_begin"] = f.node_begin;
  j["new_begin"] = f.new_begin;
  j["steps"] = f.steps;
  j["disc_radius"] = f.disc_radius;
  std::vector<double> xy;
  xy.reserve(2 * f.position.size());
  for (const dvec2& p : f.position) {
    xy.push_back(p.x);
    xy.push_back(p.y);
  }
  j["position"] = std::move(xy);
  std::vector<std::uint32_t> strand;
  strand.reserve(f.strand.size());
  for (StrandId s : f.strand) strand.push_back(s.value);
  j["strand"] = std::move(strand);
  j["strand_begin"] = f.strand_begin;
  std::vector<std::uint32_t> start;
  start.reserve(f.strand_start.size());
  for (NodeId n : f.strand_start) start.push_back(n.value);
  j["strand_start"] = std::move(start);
  const ParticleStats& st = f.stats;
  nlohmann::json timings = nlohmann::json::object();
  for (const auto& e : st.timings.entries) timings[e.name] = e.seconds;
  j["stats"] = {{"nodes", st.nodes},
                {"strands", st.strands},
                {"particles", st.particles},
                {"new_strands", st.new_strands},
                {"relaxation_steps", st.relaxation_steps},
                {"relaxed_nodes", st.relaxed_nodes},
                {"relaxed_particles", st.relaxed_particles},
                {"unconverged_nodes", st.unconverged_nodes},
                {"timings", timings},
                {"warnings", warnings_json(st.warnings)}};
  return j.dump();
}

ParticleField particles_from_json(const std::string& text) {
  check_json_nesting(text, "particles dump");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInputError(std::string("particles dump: not JSON: ") + e.what());
  }
  if (!j.is_object() || j.value("format", std::string()) != "strandmesh-particles") {
    throw InvalidInputError("particles dump: \"format\" is not \"strandmesh-particles\"");
  }
  ParticleField f;
  f.spacing = j.value("spacing", 0.0);
  f.neighbour_distance = j.value("neighbour_distance", 0.0);
  f.node_begin = get_vector<std::uint32_t>(j, "node_begin");
  f.new_begin = get_vector<std::uint32_t>(j, "new_begin");
  f.steps = get_vector<std::uint32_t>(j, "steps");
  f.disc_radius = get_vector<double>(j, "disc_radius");
  f.strand_begin = get_vector<std::uint32_t>(j, "strand_begin");
  const auto xy = get_vector<double>(j, "position");
  const auto strand = get_vector<std::uint32_t>(j, "strand");
  const auto start = get_vector<std::uint32_t>(j, "strand_start");
  if (f.node_begin.empty() || xy.size() != 2 * std::size_t(f.node_begin.back()) || strand.size() * 2 != xy.size() ||
      f.new_begin.size() + 1 != f.node_begin.size() || f.strand_begin.size() != f.node_begin.size() ||
      start.size() != f.strand_begin.back()) {
    throw InvalidInputError("particles dump: array sizes do not match node_begin / strand_begin");
  }
  f.position.resize(strand.size());
  for (std::size_t i = 0; i < strand.size(); ++i) f.position[i] = dvec2(xy[2 * i], xy[2 * i + 1]);
  f.strand.reserve(strand.size());
  for (std::uint32_t s : strand) f.strand.emplace_back(s);
  f.strand_start.reserve(start.size());
  for (std::uint32_t n : start) f.strand_start.emplace_back(n);
  f.stats.nodes = f.node_count();
  f.stats.strands = f.strand_start.size();
  f.stats.particles = f.position.size();
  return f;
}

}  // namespace sm
