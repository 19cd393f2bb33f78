// SkeletonParams' table (core/param_table.h): config key, range, unit and help of each field.

#include "skeleton/build.h"

namespace sm {
namespace {

using S = SkeletonParams;
constexpr const char* kPolicyNames[] = {"clamp_child", "raise_parent", "keep"};

const ParamSpec<S> kFields[] = {
    {.key = "max_nodes", .field = &S::max_nodes, .range = {.min = 1}, .unit = "count",
     .help = "largest accepted node count; more is rejected as malformed input",
     .slider = {1, 2e7, true}},
    {.key = "merge_edge_ratio", .field = &S::merge_edge_ratio, .range = {.min = 0}, .unit = "x larger radius",
     .help = "edges shorter than this are merged into the parent (zero-length edges always are)",
     .slider = {0, 1}},
    {.key = "radius_floor", .field = &S::radius_floor, .range = {.min = 0}, .unit = "m",
     .help = "smallest radius; 0 = the smallest positive input radius, at least 0.2% of the largest",
     .slider = {0, 0.05}},
    {.key = "max_child_ratio", .field = &S::max_child_ratio, .range = {.min = 0, .min_open = true},
     .unit = "x parent radius", .help = "a child may be this much thicker than its parent before the policy applies",
     .slider = {0.5, 3}},
    {.key = "thick_child_policy", .field = param_choice<&S::thick_child_policy>(kPolicyNames),
     .help = "what to do with a child thicker than max_child_ratio allows"},
    // (Below one radius, resampling multiplies the nodes without adding shape: 1e-9 made
    // 10,000 nodes of every edge.)
    {.key = "max_edge_ratio", .field = &S::max_edge_ratio, .range = {.min = 1, .or_zero = true}, .unit = "x radius",
     .help = "longer edges are split into equal parts (0 = off)", .slider = {0, 50}},
    {.key = "binarize_step_ratio", .field = &S::binarize_step_ratio, .range = {.min = 0}, .unit = "x radius",
     .help = "step between the extra nodes of a binarized whorl", .slider = {0.001, 0.5, true}},
    {.key = "max_chain_forks", .field = &S::max_chain_forks, .range = {.min = 0}, .unit = "count",
     .help = "hubs with more children get their laterals grouped under cluster nodes (0 = off)",
     .slider = {0, 64}},
    {.key = "merge_inner_branches", .field = &S::merge_inner_branches,
     .help = "fold branches that run inside a sibling's edge into it; drop tips hidden in their parent"},
    {.key = "collar_ratio", .field = &S::collar_ratio, .range = {.min = 0}, .unit = "x fork radius",
     .help = "collar node of a thin lateral at this distance from the fork (0 = off)", .slider = {0, 3}},
    {.key = "collar_max_child_ratio", .field = &S::collar_max_child_ratio, .range = {.min = 0},
     .unit = "x fork radius", .help = "only laterals thinner than this get a collar node", .slider = {0, 1}},
    {.key = "collar_min_stub", .field = &S::collar_min_stub, .range = {.min = 0}, .unit = "x lateral radius",
     .help = "... and only those reaching at least this far beyond the collar", .slider = {0, 4}},
    {.key = "max_lateral_angle", .field = &S::max_lateral_angle, .range = {.min = 0, .max = 180}, .unit = "degrees",
     .help = "steeper laterals get an upturned base node (from the parent's direction; 0 = off)"},
    {.key = "max_turn_back", .field = &S::max_turn_back, .range = {.min = 0, .max = 180}, .unit = "degrees",
     .help = "a child turning back more than this from its node's incoming edge is re-attached below it (0 = off)"},
    {.key = "tight_bend_ratio", .field = &S::tight_bend_ratio, .range = {.min = 0}, .unit = "x shorter edge",
     .help = "a one-child node is removed where r tan(turn/2) exceeds this and its chord passes within max_node_move (any with separate; 0 = off)", .slider = {0, 4}},
    {.key = "separate", .field = &S::separate,
     .help = "opt-in shape edits: swing crossing branches apart, re-attach hairpins, remove tight bends"},
    {.key = "max_node_move", .field = &S::max_node_move, .range = {.min = 0, .max = 1}, .unit = "x radius",
     .help = "largest move of an input node by the shape edits"},
    {.key = "branch_clearance", .field = &S::branch_clearance, .range = {.min = 0}, .unit = "x summed radii",
     .help = "gap left between separated branches", .slider = {0, 1}},
};

}  // namespace

const ParamTable<SkeletonParams>& param_table(std::type_identity<SkeletonParams>) {
  static const ParamTable<SkeletonParams> t{"skeleton", kFields};
  return t;
}

}  // namespace sm
