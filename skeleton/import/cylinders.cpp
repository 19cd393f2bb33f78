#include "skeleton/import/cylinders.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "core/errors.h"

namespace sm {
namespace {

constexpr std::size_t kNone = static_cast<std::size_t>(-1);

/// How far two points may lie apart and still be one point: 1 % of the thinner cylinder's
/// radius, plus the float32 resolution of coordinates far from the origin (TreeQSM stores
/// single precision; georeferenced z is about 254 m, a step of 1.5e-5 m).
double tolerance(double r_a, double r_b, const dvec3& p) {
  const double r = std::min(std::abs(r_a), std::abs(r_b));
  const double far = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
  return 0.01 * (std::isfinite(r) ? r : 0.0) + 1e-7 * (std::isfinite(far) ? far : 0.0);
}

}  // namespace

RawSkeleton cylinders_to_skeleton(const CylinderTable& t) {
  const std::size_t n = t.size();
  const std::string& src = t.source;
  if (n == 0) throw InvalidInputError(src + ": no cylinders");
  auto where = [&](std::size_t i) { return i < t.where.size() ? t.where[i] : "cylinder id " + std::to_string(t.id[i]); };

  std::unordered_map<std::int64_t, std::size_t> index;
  index.reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto [it, fresh] = index.emplace(t.id[i], i);
    if (!fresh) {
      throw InvalidInputError(src + ": " + where(i) + ": cylinder id " + std::to_string(t.id[i]) + " is also the id at " +
                              where(it->second) + " (ids must be distinct)");
    }
  }
  const bool has_zero_id = index.count(0) > 0;
  std::vector<std::size_t> parent(n, kNone);
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t p = t.parent[i];
    if (const auto it = index.find(p); it != index.end()) {
      if (it->second == i) throw InvalidInputError(src + ": " + where(i) + ": the cylinder is its own parent");
      parent[i] = it->second;
    } else if (!(p < 0 || (p == 0 && !has_zero_id))) {
      throw InvalidInputError(src + ": " + where(i) + ": parent id " + std::to_string(p) +
                              " is no cylinder's id (a root has a negative parent, or 0 when the ids start at 1)");
    }
  }
  // Children in file order (CSR), then a pre-order walk from the roots: parents before children.
  std::vector<std::size_t> first(n + 1, 0), kids(n);
  for (std::size_t i = 0; i < n; ++i)
    if (parent[i] != kNone) ++first[parent[i] + 1];
  for (std::size_t i = 0; i < n; ++i) first[i + 1] += first[i];
  {
    std::vector<std::size_t> fill(first.begin(), first.end() - 1);
    for (std::size_t i = 0; i < n; ++i)
      if (parent[i] != kNone) kids[fill[parent[i]]++] = i;
  }
  std::vector<std::size_t> order;
  order.reserve(n);
  std::vector<char> seen(n, 0);
  std::vector<std::size_t> stack;
  for (std::size_t r = 0; r < n; ++r) {
    if (parent[r] != kNone) continue;
    stack.push_back(r);
    while (!stack.empty()) {
      const std::size_t c = stack.back();
      stack.pop_back();
      seen[c] = 1;
      order.push_back(c);
      for (std::size_t k = first[c + 1]; k > first[c]; --k) stack.push_back(kids[k - 1]);
    }
  }
  if (order.size() < n) {
    const auto it = std::find(seen.begin(), seen.end(), 0);
    throw InvalidInputError(src + ": " + where(std::size_t(it - seen.begin())) +
                            ": the cylinder's parents form a cycle (its parent chain never reaches a root)");
  }

  // Where each child starts on its parent: t = 1 at the parent's end (continuations), t in
  // [0, 1] along the parent's axis otherwise.
  const bool has_extension = t.extension.size() == n;
  std::vector<double> at(n, 1.0);
  std::vector<char> continues(n, 0);
  for (std::size_t c = 0; c < n; ++c) {
    const std::size_t p = parent[c];
    if (p == kNone) continue;
    const double tol = tolerance(t.radius[c], t.radius[p], t.start[c]);
    continues[c] = has_extension ? t.extension[p] == t.id[c] : glm::length(t.start[c] - t.end[p]) <= tol;
    if (continues[c]) continue;
    const dvec3 axis = t.end[p] - t.start[p];
    const double len2 = glm::dot(axis, axis);
    double s = len2 > 0 ? glm::dot(t.start[c] - t.start[p], axis) / len2 : 1.0;
    if (!std::isfinite(s)) s = 1.0;  // non-finite input: validation names the node later
    s = std::clamp(s, 0.0, 1.0);
    const double len = std::sqrt(len2);
    if (s * len <= tol) s = 0.0;
    if ((1.0 - s) * len <= tol) s = 1.0;
    at[c] = s;
  }

  RawSkeleton raw;
  raw.source = src;
  raw.up_axis = UpAxis::z;
  auto add = [&](std::size_t parent_node, const dvec3& pos, double r, std::string place) {
    const std::size_t k = raw.size();
    raw.id.push_back(static_cast<std::int64_t>(k));
    raw.parent_id.push_back(parent_node == kNone ? -1 : static_cast<std::int64_t>(parent_node));
    raw.position.push_back(pos);
    raw.radius.push_back(r);
    raw.where.push_back(std::move(place));
    return k;
  };
  std::vector<std::size_t> base_node(n, kNone), end_node(n, kNone), attach_node(n, kNone);
  std::vector<std::pair<double, std::size_t>> splits;  // (t, child) of the cylinder being emitted
  for (const std::size_t c : order) {
    const std::size_t p = parent[c];
    std::size_t base = kNone;
    if (p == kNone) {
      base = add(kNone, t.start[c], t.radius[c], where(c) + ": start");
    } else if (continues[c]) {
      base = end_node[p];
    } else {
      const std::size_t a = at[c] == 0.0 ? base_node[p] : at[c] == 1.0 ? end_node[p] : attach_node[c];
      base = glm::length(t.start[c] - raw.position[a]) <= tolerance(t.radius[c], t.radius[p], t.start[c])
                 ? a
                 : add(a, t.start[c], t.radius[c], where(c) + ": start");
    }
    base_node[c] = base;
    // Split this cylinder where its side branches start, in order along it; starts closer than
    // the tolerance share one node.
    splits.clear();
    for (std::size_t k = first[c]; k < first[c + 1]; ++k) {
      const std::size_t child = kids[k];
      if (at[child] > 0.0 && at[child] < 1.0) splits.emplace_back(at[child], child);
    }
    std::sort(splits.begin(), splits.end());
    const dvec3 from = raw.position[base];
    const double len = glm::length(t.end[c] - from);
    std::size_t prev = base;
    double prev_t = -1.0;
    for (const auto& [s, child] : splits) {
      if (prev != base && (s - prev_t) * len <= tolerance(t.radius[c], t.radius[child], t.end[c])) {
        attach_node[child] = prev;
        continue;
      }
      prev = add(prev, from + s * (t.end[c] - from), t.radius[c],
                 where(c) + ": on its axis where " + where(child) + " starts");
      prev_t = s;
      attach_node[child] = prev;
    }
    end_node[c] = add(prev, t.end[c], t.radius[c], where(c) + ": end");
  }
  return raw;
}

}  // namespace sm
