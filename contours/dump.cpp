// The contour dump (contours/dump.h): written by `dump_stages` (pipeline/pipeline.cpp), read
// back by the viewer (viewer/run.cpp), which recomputes what the file does not store.

#include "contours/dump.h"

#include <algorithm>
#include <cstdint>
#include <unordered_map>

#include <nlohmann/json.hpp>

#include "core/errors.h"
#include "core/input_limits.h"
#include "core/math.h"

namespace sm {

namespace {

const nlohmann::json& require(const nlohmann::json& j, const char* key, const std::string& where) {
  if (!j.is_object() || !j.contains(key)) throw InvalidInputError(where + ": missing key \"" + key + "\"");
  return j.at(key);
}

glm::dvec3 vec3_of(const nlohmann::json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3 || !j[0].is_number() || !j[1].is_number() || !j[2].is_number()) {
    throw InvalidInputError(where + ": expected [x, y, z]");
  }
  return {j[0].get<double>(), j[1].get<double>(), j[2].get<double>()};
}

// The slice frame the contours stage uses for a slice at parameter t on the edge of node n:
// the parent's frame transported to the interpolated tangent (contours.cpp, edge_geometry).
Frame slice_frame(const Skeleton& s, NodeId n, double t) {
  const NodeId p = s.parent[n.idx()];
  if (!p.valid()) return s.frame[n.idx()];
  const Frame& fp = s.frame[p.idx()];
  const Frame& fn = s.frame[n.idx()];
  const dvec3 tangent = normalize_or(glm::mix(fp.tangent, fn.tangent, t), fn.tangent);
  return transport_frame(fp, tangent);
}

}  // namespace

std::string contours_to_json(const ContourSet& c) {
  using nlohmann::json;
  static const char* kinds[] = {"plain", "fused", "split", "tip"};
  json loops = json::array();
  for (std::uint32_t l = 0; l < c.loop_count(); ++l) {
    json strands = json::array(), points = json::array();
    for (std::uint32_t v = c.loop_begin[l]; v < c.loop_begin[l + 1]; ++v) {
      strands.push_back(c.strand[v].valid() ? std::int64_t(c.strand[v].value) : -1);
      points.push_back({c.point[v].x, c.point[v].y, c.point[v].z});
    }
    const auto& ctr = c.loop_center[l];
    loops.push_back({{"node", c.loop_node[l].value},
                     {"t", c.loop_t[l]},
                     {"kind", kinds[static_cast<int>(c.loop_kind[l])]},
                     {"distance", c.loop_distance[l]},
                     {"radius", c.loop_radius[l]},
                     {"center", {ctr.x, ctr.y, ctr.z}},
                     {"strands", std::move(strands)},
                     {"points", std::move(points)}});
  }
  json tubes = json::array();
  for (const auto& t : c.tubes) {
    tubes.push_back({{"loops", t.loops},
                     {"branch", t.branch.value},
                     {"start_junction", t.start_junction == UINT32_MAX ? -1 : std::int64_t(t.start_junction)},
                     {"end_junction", t.end_junction == UINT32_MAX ? -1 : std::int64_t(t.end_junction)}});
  }
  json junctions = json::array();
  for (const auto& j : c.junctions) {
    junctions.push_back({{"fork", j.fork.value},
                         {"lower", j.lower},
                         {"upper", {j.upper[0], j.upper[1]}},
                         {"split_distance", j.split_distance},
                         {"forced", j.forced}});
  }
  return json{{"loops", std::move(loops)}, {"tubes", std::move(tubes)}, {"junctions", std::move(junctions)}}.dump() +
         "\n";
}

ContourSet contours_from_json(const std::string& text, const Skeleton& skeleton, const std::string& name,
                              const ParticleField* field) {
  check_json_nesting(text, name);
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InvalidInputError(name + ": not JSON: " + e.what());
  } catch (const nlohmann::json::exception& e) {  // a number overflow (out_of_range.406) carries no position
    const std::string place = json_error_line_col(text);
    throw InvalidInputError(name + (place.empty() ? "" : ":" + place) + ": not JSON: " + e.what());
  }
  ContourSet c;
  c.loop_begin.push_back(0);
  const auto& loops = require(j, "loops", name);
  if (!loops.is_array()) throw InvalidInputError(name + ": \"loops\" is not an array");
  try {
    for (std::size_t l = 0; l < loops.size(); ++l) {
      const std::string where = name + ": loops[" + std::to_string(l) + "]";
      const auto& L = loops[l];
      const std::int64_t node = require(L, "node", where).get<std::int64_t>();
      if (node < 0 || static_cast<std::size_t>(node) >= skeleton.size()) {
        throw InvalidInputError(where + ": node " + std::to_string(node) + " is not a node of skeleton.json");
      }
      const double t = require(L, "t", where).get<double>();
      const std::string kind = require(L, "kind", where).get<std::string>();
      LoopKind k = LoopKind::plain;
      if (kind == "plain")
        k = LoopKind::plain;
      else if (kind == "fused")
        k = LoopKind::fused;
      else if (kind == "split")
        k = LoopKind::split;
      else if (kind == "tip")
        k = LoopKind::tip;
      else
        throw InvalidInputError(where + ": unknown kind \"" + kind + "\" (plain, fused, split, tip)");
      const auto& strands = require(L, "strands", where);
      const auto& points = require(L, "points", where);
      if (!strands.is_array() || !points.is_array() || strands.size() != points.size()) {
        throw InvalidInputError(where + ": \"strands\" and \"points\" must be arrays of equal length");
      }
      for (std::size_t v = 0; v < points.size(); ++v) {
        c.point.push_back(vec3_of(points[v], where + ".points[" + std::to_string(v) + "]"));
        const std::int64_t s = strands[v].get<std::int64_t>();
        c.strand.push_back(s < 0 ? StrandId{} : StrandId(static_cast<std::uint32_t>(s)));
      }
      c.loop_begin.push_back(static_cast<std::uint32_t>(c.point.size()));
      const NodeId n(static_cast<std::uint32_t>(node));
      c.loop_node.push_back(n);
      c.loop_t.push_back(t);
      c.loop_distance.push_back(L.value("distance", 0.0));
      c.loop_radius.push_back(L.value("radius", skeleton.radius[n.idx()]));
      c.loop_center.push_back(L.contains("center") ? vec3_of(L["center"], where + ".center")
                                                   : skeleton.position[n.idx()]);
      c.loop_frame.push_back(slice_frame(skeleton, n, t));
      c.loop_kind.push_back(k);
      if (k == LoopKind::fused) ++c.stats.fused_loops;
    }
    const std::uint32_t loop_count = static_cast<std::uint32_t>(c.loop_kind.size());
    auto loop_index = [&](const nlohmann::json& v, const std::string& where) {
      const std::int64_t i = v.get<std::int64_t>();
      if (i < 0 || i >= loop_count) throw InvalidInputError(where + ": loop " + std::to_string(i) + " does not exist");
      return static_cast<std::uint32_t>(i);
    };
    if (j.contains("tubes")) {
      for (std::size_t t = 0; t < j["tubes"].size(); ++t) {
        const std::string where = name + ": tubes[" + std::to_string(t) + "]";
        const auto& T = j["tubes"][t];
        Tube tube;
        for (const auto& l : require(T, "loops", where)) tube.loops.push_back(loop_index(l, where));
        tube.branch = NodeId(static_cast<std::uint32_t>(T.value("branch", 0)));
        const std::int64_t sj = T.value("start_junction", std::int64_t(-1));
        const std::int64_t ej = T.value("end_junction", std::int64_t(-1));
        tube.start_junction = sj < 0 ? UINT32_MAX : static_cast<std::uint32_t>(sj);
        tube.end_junction = ej < 0 ? UINT32_MAX : static_cast<std::uint32_t>(ej);
        c.tubes.push_back(std::move(tube));
      }
    }
    if (j.contains("junctions")) {
      for (std::size_t k = 0; k < j["junctions"].size(); ++k) {
        const std::string where = name + ": junctions[" + std::to_string(k) + "]";
        const auto& J = j["junctions"][k];
        Junction jn;
        jn.fork = NodeId(static_cast<std::uint32_t>(require(J, "fork", where).get<std::int64_t>()));
        jn.lower = loop_index(require(J, "lower", where), where);
        const auto& up = require(J, "upper", where);
        if (!up.is_array() || up.size() != 2) throw InvalidInputError(where + ": \"upper\" must hold two loops");
        jn.upper = {loop_index(up[0], where), loop_index(up[1], where)};
        jn.split_distance = J.value("split_distance", 0.0);
        jn.forced = J.value("forced", false);
        if (jn.forced) ++c.stats.forced_splits;
        c.junctions.push_back(jn);
      }
    }
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInputError(name + ": wrong value type: " + e.what());
  }
  // The tube indices of each junction follow from the tubes' start and end junctions.
  for (std::uint32_t t = 0; t < c.tubes.size(); ++t) {
    const Tube& tube = c.tubes[t];
    if (tube.end_junction < c.junctions.size()) c.junctions[tube.end_junction].lower_tube = t;
    if (tube.start_junction < c.junctions.size()) {
      Junction& jn = c.junctions[tube.start_junction];
      if (!tube.loops.empty() && tube.loops.front() == jn.upper[1])
        jn.upper_tubes[1] = t;
      else
        jn.upper_tubes[0] = t;
    }
  }
  if (field && field->node_count() == skeleton.size()) {
    // Which bundle each lower-loop strand belongs to: particle order at the fork is
    // [main child's strands | lateral's | new at the fork] (particles/particles.h).
    for (Junction& jn : c.junctions) {
      const NodeId fork = jn.fork;
      if (!fork.valid() || fork.idx() >= skeleton.size() || !skeleton.is_fork(fork)) {
        throw InvalidInputError(name + ": junction at node " + std::to_string(fork.value) + ", which is not a fork");
      }
      const std::uint32_t base = field->node_begin[fork.idx()];
      const std::uint32_t n_main = field->count(skeleton.children[fork.idx()][0]);
      const std::uint32_t n_both = std::min(field->new_begin[fork.idx()], field->count(fork));
      std::unordered_map<std::uint32_t, std::uint8_t> side;
      for (std::uint32_t q = 0; q < n_both; ++q) side.emplace(field->strand[base + q].value, q < n_main ? 0 : 1);
      jn.lower_side.assign(c.loop_size(jn.lower), 2);
      for (std::uint32_t k = 0; k < jn.lower_side.size(); ++k) {
        const auto it = side.find(c.strand[c.loop_begin[jn.lower] + k].value);
        if (it != side.end()) jn.lower_side[k] = it->second;
      }
    }
  }
  c.stats.loops = c.loop_count();
  c.stats.loop_vertices = c.point.size();
  return c;
}

}  // namespace sm
