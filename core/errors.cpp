#include "core/errors.h"

namespace sm {

void check_invariant(bool cond, const char* what, const char* file, int line) {
  if (!cond) {
    throw InternalError(std::string("internal error: ") + what + " (" + file + ":" + std::to_string(line) + ")");
  }
}

}  // namespace sm
