// Accepted ranges of parameters: the test and the rule as messages and docs print it.

#include "core/param_table.h"

#include <cstdio>

namespace sm {

bool ParamRange::contains(double x) const {
  if (!std::isfinite(x)) return false;
  if (or_zero && x == 0) return true;
  const bool above = min_open ? x > min : x >= min;
  const bool below = max_open ? x < max : x <= max;
  return above && below;
}

namespace {
std::string number(double x) {
  char s[40];
  std::snprintf(s, sizeof s, "%g", x);
  return s;
}
}  // namespace

std::string ParamRange::rule() const {
  const bool low = std::isfinite(min), high = std::isfinite(max);
  std::string r;
  if (low && high) {
    r = std::string("in ") + (min_open ? "(" : "[") + number(min) + ", " + number(max) + (max_open ? ")" : "]");
  } else if (low) {
    r = (or_zero ? (min_open ? "above " : "at least ") : (min_open ? "> " : ">= ")) + number(min);
  } else if (high) {
    r = (max_open ? "< " : "<= ") + number(max);
  } else {
    r = "any";
  }
  return or_zero ? "0 (off) or " + r : r;
}

}  // namespace sm
