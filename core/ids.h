#pragma once
/// Strong integer ids for nodes and strands.
///
/// An id is a 32-bit index into a stage's structure-of-arrays data. The default-constructed
/// id is invalid (`!id.valid()`), which stands for "no node" (the root's parent, a missing
/// child).

#include <compare>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <limits>

namespace sm {

template <class Tag>
struct Id {
  static constexpr std::uint32_t invalid_value = std::numeric_limits<std::uint32_t>::max();

  std::uint32_t value = invalid_value;

  constexpr Id() = default;
  constexpr explicit Id(std::uint32_t v) : value(v) {}
  constexpr explicit Id(std::size_t v) : value(static_cast<std::uint32_t>(v)) {}
  constexpr explicit Id(int v) : value(static_cast<std::uint32_t>(v)) {}

  [[nodiscard]] constexpr bool valid() const { return value != invalid_value; }
  /// The id as an array index. Precondition: valid().
  [[nodiscard]] constexpr std::size_t idx() const { return value; }

  friend constexpr auto operator<=>(Id, Id) = default;
};

using NodeId = Id<struct NodeTag>;
using StrandId = Id<struct StrandTag>;

}  // namespace sm

template <class Tag>
struct std::hash<sm::Id<Tag>> {
  std::size_t operator()(sm::Id<Tag> id) const noexcept { return std::hash<std::uint32_t>{}(id.value); }
};
