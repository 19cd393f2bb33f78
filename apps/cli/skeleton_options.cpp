#include "apps/cli/skeleton_options.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstdio>
#include <map>
#include <string_view>
#include <tuple>

#include "apps/cli/param_help.h"
#include "core/errors.h"
#include "core/file_io.h"
#include "core/log.h"
#include "skeleton/io.h"

namespace sm::cli {

namespace {

const ParamSpec<SkeletonParams>& spec(std::string_view key) { return param_spec<SkeletonParams>(key); }

std::string help_of(std::string_view key, const std::string& more = "") { return param_help<SkeletonParams>(key, more); }

CLI::Validator range_of(std::string_view key) {
  const ParamRange r = spec(key).range;
  return CLI::Validator(
      [r](std::string& in) -> std::string {
        char* end = nullptr;
        const double x = std::strtod(in.c_str(), &end);
        if (end == in.c_str() || *end != '\0') return {};  // not a number: the conversion reports it
        return r.contains(x) ? std::string() : "must be " + r.rule() + ", got " + in;
      },
      "");
}

}  // namespace

void add_skeleton_options(CLI::App& sub, SkeletonParams& p) {
  sub.add_option("--max-nodes", p.max_nodes, help_of("max_nodes"))
      ->capture_default_str()
      ->check(kNotNegative)
      ->check(range_of("max_nodes"));
  for (const auto& [flag, key, member] : {std::tuple{"--merge-edge-ratio", "merge_edge_ratio", &p.merge_edge_ratio},
                                          std::tuple{"--radius-floor", "radius_floor", &p.radius_floor},
                                          std::tuple{"--max-child-ratio", "max_child_ratio", &p.max_child_ratio},
                                          std::tuple{"--max-edge-ratio", "max_edge_ratio", &p.max_edge_ratio}}) {
    sub.add_option(flag, *member, help_of(key))->capture_default_str()->check(range_of(key));
  }
  const std::map<std::string, ThickChildPolicy> policies{{"clamp", ThickChildPolicy::clamp_child},
                                                         {"raise", ThickChildPolicy::raise_parent},
                                                         {"keep", ThickChildPolicy::keep}};
  sub.add_option("--thick-child", p.thick_child_policy, help_of("thick_child_policy", "; here clamp, raise or keep"))
      ->transform(CLI::CheckedTransformer(policies, CLI::ignore_case))
      ->default_str("keep");
  sub.add_flag("!--keep-input", p.separate,
               "Keep the input where it is (the default): crossing branches are not swung apart nor hairpins "
               "re-attached; the repair stage fuses crossings where they are");
  sub.add_flag("--separate", p.separate,
               "Swing crossing branches apart, re-attach hairpins and remove tight bends (moves the input; "
               "configs/separate.json has every shape edit of earlier versions)");
}

void check_json_output(const std::string& path, const char* option) {
  if (extension_of(path) != "json") {
    throw InvalidInputError(path + ": " + option + " writes JSON; the file name must end in .json");
  }
  check_output_path(path);
}

SkeletonResult load_skeleton(const std::string& path, const SkeletonParams& params, const ReadOptions& read) {
  SkeletonResult result = build_skeleton(read_skeleton(path, read), params);
  print_warnings(result.report.warnings, log::level() == log::Level::verbose);
  return result;
}

std::string describe_skeleton(const SkeletonResult& result) {
  const Skeleton& s = result.skeleton;
  const SkeletonReport& r = result.report;
  std::size_t tips = 0, forks = 0;
  double total_length = 0, rmin = 1e300, rmax = 0;
  dvec3 lo(1e300), hi(-1e300);
  for (std::size_t i = 0; i < s.size(); ++i) {
    const NodeId n(i);
    tips += s.is_tip(n) ? 1 : 0;
    forks += s.is_fork(n) ? 1 : 0;
    total_length += s.edge_length(n);
    rmin = std::min(rmin, s.radius[i]);
    rmax = std::max(rmax, s.radius[i]);
    lo = glm::min(lo, s.position[i]);
    hi = glm::max(hi, s.position[i]);
  }
  const auto d = s.depths();
  const std::uint32_t depth = d.empty() ? 0 : *std::max_element(d.begin(), d.end());
  char buf[2048];
  std::string out;
  std::snprintf(buf, sizeof buf,
                "nodes            %zu (input %zu)\n"
                "tips             %zu\n"
                "forks            %zu\n"
                "depth            %u edges\n"
                "radius           %.6g .. %.6g m\n"
                "total length     %.6g m\n"
                "extent           [%.6g, %.6g, %.6g] .. [%.6g, %.6g, %.6g] (up axis %s)\n",
                s.size(), r.input_nodes, tips, forks, depth, rmin, rmax, total_length, lo.x, lo.y, lo.z, hi.x, hi.y,
                hi.z, s.up_axis == UpAxis::y ? "y" : "z");
  out += buf;
  std::snprintf(buf, sizeof buf,
                "sanitize report\n"
                "  merged edges     %zu\n"
                "  raised radii     %zu (floor %.6g m)\n"
                "  clamped children %zu\n"
                "  resampled edges  %zu\n"
                "  binarized nodes  %zu\n"
                "  inserted nodes   %zu\n"
                "  inner branches   %zu nodes folded into a sibling\n"
                "  hairpins         %zu branches turning back re-attached below their node\n"
                "  hidden tips      %zu tips wholly inside their parent's branch removed\n"
                "  tight bends      %zu nodes where a branch turned too sharply removed\n"
                "  separated pairs  %zu (largest move %.3g m, %zu unresolved)\n"
                "  collar nodes     %zu (a refinement, not a repair)\n"
                "  raised laterals  %zu (steep laterals given an upturned base; a refinement)\n"
                "  dropped nodes    %zu input nodes without a node of the result (merged or removed)\n"
                "  node moves       largest %.3g m (%.3g radii), 95th percentile %.3g radii\n",
                r.merged_edges, r.raised_radii, r.radius_floor, r.clamped_children, r.resampled_edges,
                r.binarized_nodes, r.inserted_nodes, r.merged_inner, r.hairpins, r.hidden_tips, r.tight_bends,
                r.branch_collisions, r.max_separation, r.unresolved_collisions, r.collars, r.raised_laterals,
                r.dropped_nodes, r.max_move, r.max_move_radii, r.p95_move_radii);
  out += buf;
  return out;
}

}  // namespace sm::cli
