#pragma once
/// Union-find over 0..n-1 (path halving; a union keeps the smaller root), for grouping
/// triangles or vertices into connected sets.

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <vector>

namespace sm {

class UnionFind {
 public:
  explicit UnionFind(std::size_t n) : parent_(n) { std::iota(parent_.begin(), parent_.end(), 0u); }
  /// Back to n singletons, keeping the storage (for many small sets in a loop).
  void reset(std::size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), 0u);
  }
  /// The root of x's set: the smallest element ever united into it.
  std::uint32_t find(std::uint32_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  void unite(std::uint32_t a, std::uint32_t b) {
    a = find(a);
    b = find(b);
    if (a != b) parent_[std::max(a, b)] = std::min(a, b);
  }

 private:
  std::vector<std::uint32_t> parent_;
};

}  // namespace sm
