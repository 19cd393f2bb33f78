#include "core/errors.h"

#include <cmath>
#include <cstdio>

namespace sm {

void check_invariant(bool cond, const char* what, const char* file, int line) {
  if (!cond) {
    throw InternalError(std::string("internal error: ") + what + " (" + file + ":" + std::to_string(line) + ")");
  }
}

void ParamChecker::require(bool ok, const char* key, const char* rule, double got) const {
  if (ok) return;
  char line[200];
  std::snprintf(line, sizeof line, "%s.%s must be %s, got %g", section, key, rule, got);
  throw InvalidInputError(line);
}

void ParamChecker::positive(double x, const char* key) const {
  require(std::isfinite(x) && x > 0, key, "> 0", x);
}

void ParamChecker::non_negative(double x, const char* key) const {
  require(std::isfinite(x) && x >= 0, key, ">= 0", x);
}

void ParamChecker::within(double x, double lo, double hi, const char* key) const {
  char rule[80];
  std::snprintf(rule, sizeof rule, "in [%g, %g]", lo, hi);
  require(std::isfinite(x) && x >= lo && x <= hi, key, rule, x);
}

}  // namespace sm
