// StrandParams' table (core/param_table.h): config key, range, unit and help of each field.

#include "strands/strands.h"

namespace sm {
namespace {

const ParamSpec<StrandParams> kFields[] = {
    {.key = "alpha", .field = &StrandParams::alpha, .range = {.min = 0, .max = 1},
     .help = "Catmull-Rom exponent: 0 uniform, 0.5 centripetal, 1 chordal"},
};

}  // namespace

const ParamTable<StrandParams>& param_table(std::type_identity<StrandParams>) {
  static const ParamTable<StrandParams> t{"strands", kFields};
  return t;
}

}  // namespace sm
