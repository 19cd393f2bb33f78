// RepairParams' table (core/param_table.h): config key, range, unit and help of each field.

#include "repair/repair.h"

namespace sm {
namespace {

using R = RepairParams;

const ParamSpec<R> kFields[] = {
    {.key = "self_union", .field = &R::self_union,
     .help = "replace self-intersecting parts of the surface by their union"},
    {.key = "max_rounds", .field = &R::max_rounds, .range = {.min = 0, .max = 100}, .unit = "count",
     .help = "rounds of finding pairs and cutting them", .slider = {0, 10}},
    {.key = "fold_rounds", .field = &R::fold_rounds, .range = {.min = 0, .max = 1000}, .unit = "count",
     .help = "rounds of fold repair on nearby pairs before the union (0 = none)", .slider = {0, 16}},
    {.key = "fold_max_move", .field = &R::fold_max_move, .range = {.min = 0, .max = 1}, .unit = "x local radius",
     .help = "largest vertex move of the fold repair"},
    {.key = "count_pairs_up_to", .field = &R::count_pairs_up_to, .range = {.min = 0}, .unit = "triangles",
     .help = "largest mesh whose pairs are looked for everywhere; a larger one skips this stage",
     .slider = {1000, 1e9, true}},
};

}  // namespace

const ParamTable<RepairParams>& param_table(std::type_identity<RepairParams>) {
  static const ParamTable<RepairParams> t{"repair", kFields};
  return t;
}

}  // namespace sm
