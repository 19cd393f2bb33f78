#pragma once
/// "Did you mean": the closest of a set of names to a mistyped one.

#include <string>
#include <string_view>
#include <vector>

namespace sm {

/// The name in `names` closest to `word` by edit distance (case-insensitive; insertions,
/// deletions, substitutions and swaps of neighbours), or "" when none is within a third of
/// the longer one's length (at least 1, at most 3 edits): too far to be a typo.
std::string closest_name(std::string_view word, const std::vector<std::string>& names);

}  // namespace sm
