// JSON dump of strand curves (format in dump.h).

#include "strands/dump.h"

#include <nlohmann/json.hpp>

#include "core/errors.h"

namespace sm {
namespace {

std::vector<double> flatten(const std::vector<dvec3>& v) {
  std::vector<double> out;
  out.reserve(3 * v.size());
  for (const dvec3& p : v) {
    out.push_back(p.x);
    out.push_back(p.y);
    out.push_back(p.z);
  }
  return out;
}

}  // namespace

std::string strands_to_json(const Skeleton& sk, const ParticleField& f, const StrandSet& strands,
                            const StrandParams& params) {
  SM_CHECK(f.node_count() == sk.size(), "strands_to_json: field and skeleton differ in node count");
  SM_CHECK(strands.point.size() == f.position.size(), "strands_to_json: strands and field differ in particle count");
  const std::size_t n = sk.size();
  std::vector<std::int64_t> parent_global(f.position.size(), -1);
  for (std::size_t i = 1; i < n; ++i) {
    const NodeId node(i), parent = sk.parent[i];
    for (std::uint32_t j = 0; j < f.count(node); ++j) {
      parent_global[f.global(node, j)] = f.global(parent, parent_index(sk, f, node, j));
    }
  }
  std::vector<std::uint32_t> strand, start, start_global;
  strand.reserve(f.strand.size());
  for (StrandId s : f.strand) strand.push_back(s.value);
  for (std::size_t s = 0; s < f.strand_count(); ++s) {
    start.push_back(f.strand_start[s].value);
    start_global.push_back(f.global(f.strand_start[s], f.start_local(StrandId(s))));
  }
  nlohmann::json j;
  j["format"] = "strandmesh-strands";
  j["version"] = 1;
  j["alpha"] = params.alpha;
  j["nodes"] = n;
  j["particles"] = f.position.size();
  j["strands"] = f.strand_count();
  j["node_begin"] = f.node_begin;
  j["strand"] = std::move(strand);
  j["parent_global"] = std::move(parent_global);
  j["strand_start"] = std::move(start);
  j["start_global"] = std::move(start_global);
  // The tangents, computed from the points (StrandSet::tangents; zeros at the root).
  std::vector<dvec3> tangent(f.position.size(), dvec3(0)), tangent_parent(f.position.size(), dvec3(0));
  for (std::size_t i = 1; i < n; ++i) {
    const NodeId node(i);
    for (std::uint32_t k = 0; k < f.count(node); ++k) {
      const SegmentTangents m = strands.tangents(sk, f, node, k);
      tangent[f.global(node, k)] = m.at_node;
      tangent_parent[f.global(node, k)] = m.at_parent;
    }
  }
  j["point"] = flatten(strands.point);
  j["tangent"] = flatten(tangent);
  j["tangent_parent"] = flatten(tangent_parent);
  nlohmann::json timings = nlohmann::json::object();
  for (const auto& e : strands.stats.timings.entries) timings[e.name] = e.seconds;
  nlohmann::json warnings = nlohmann::json::array();
  for (const Warning& w : strands.stats.warnings.list()) {
    warnings.push_back({{"kind", w.kind}, {"message", w.message}, {"count", w.count}, {"examples", w.examples}});
  }
  j["stats"] = {{"strands", strands.stats.strands},
                {"segments", strands.stats.segments},
                {"timings", timings},
                {"warnings", warnings}};
  return j.dump();
}

}  // namespace sm
