#include "skeleton/skeleton.h"

#include <algorithm>

#include "core/errors.h"

namespace sm {

std::size_t RawSkeleton::add(std::int64_t node_id, std::int64_t parent, dvec3 pos, double r) {
  id.push_back(node_id);
  parent_id.push_back(parent);
  position.push_back(pos);
  radius.push_back(r);
  if (!where.empty()) where.emplace_back();
  if (!base_radius.empty()) base_radius.push_back(0.0);
  return id.size() - 1;
}

std::string RawSkeleton::place(std::size_t i) const {
  if (i < where.size() && !where[i].empty()) return where[i];
  return "node id " + std::to_string(id[i]);
}

double Skeleton::edge_length(NodeId n) const {
  const NodeId p = parent[n.idx()];
  return p.valid() ? glm::length(position[n.idx()] - position[p.idx()]) : 0.0;
}

std::vector<std::uint32_t> Skeleton::depths() const {
  std::vector<std::uint32_t> d(size(), 0);
  for (std::size_t i = 1; i < size(); ++i) d[i] = d[parent[i].idx()] + 1;  // parent[i] < i
  return d;
}

std::vector<std::uint32_t> Skeleton::branch_ids() const {
  std::vector<std::uint32_t> b(size(), 0);
  for (std::size_t i = 1; i < size(); ++i) {
    const NodeId p = parent[i];
    b[i] = children[p.idx()][0] == NodeId(i) ? b[p.idx()] : static_cast<std::uint32_t>(i);
  }
  return b;
}

double Skeleton::median_radius() const {
  if (radius.empty()) return 0;
  std::vector<double> r = radius;
  const auto k = static_cast<std::ptrdiff_t>((r.size() + 1) / 2 - 1);
  std::nth_element(r.begin(), r.begin() + k, r.end());
  return r[static_cast<std::size_t>(k)];
}

std::string Skeleton::describe(NodeId n) const {
  std::string s = "node " + std::to_string(n.value);
  if (n.idx() < source_id.size()) {
    if (source_id[n.idx()] >= 0) {
      s += " (input id " + std::to_string(source_id[n.idx()]) + ")";
    } else {
      s += " (inserted)";
    }
  }
  return s;
}

NodeId Skeleton::add_node(NodeId p, dvec3 pos, double r, std::int64_t source) {
  const NodeId n(position.size());
  if (p.valid()) {
    SM_CHECK(p.idx() < size(), "add_node: parent out of range");
    auto& c = children[p.idx()];
    SM_CHECK(!c[1].valid(), "add_node: parent already has two children");
    (c[0].valid() ? c[1] : c[0]) = n;
  } else {
    SM_CHECK(empty(), "add_node: only the first node may be a root");
  }
  position.push_back(pos);
  radius.push_back(r);
  parent.push_back(p);
  children.push_back({NodeId{}, NodeId{}});
  frame.emplace_back();
  source_id.push_back(source);
  if (base_radius.size() + 1 == position.size()) base_radius.push_back(0.0);
  return n;
}

RawSkeleton raw_from_skeleton(const Skeleton& s, const std::string& source) {
  RawSkeleton out;
  out.up_axis = s.up_axis;
  out.source = source;
  for (std::size_t i = 0; i < s.size(); ++i) {
    out.add(static_cast<std::int64_t>(i), s.parent[i].valid() ? std::int64_t(s.parent[i].value) : -1, s.position[i],
            s.radius[i]);
  }
  if (s.base_radius.size() == s.size() &&
      std::any_of(s.base_radius.begin(), s.base_radius.end(), [](double b) { return b > 0; })) {
    out.base_radius = s.base_radius;
  }
  return out;
}

}  // namespace sm
