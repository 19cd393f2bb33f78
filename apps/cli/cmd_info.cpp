// strandmesh info SKELETON: what the skeleton stage made of a file.

#include <cstdio>

#include <nlohmann/json.hpp>

#include "apps/cli/commands.h"
#include "apps/cli/input_options.h"
#include "apps/cli/skeleton_options.h"
#include "skeleton/io.h"

namespace sm::cli {

void add_info_command(CLI::App& app, const GlobalOptions&) {
  add_command(app, "info", "Load, validate and sanitize a skeleton and print a report", [](CLI::App& sub) -> Action {
    struct Opts {
      std::string input;
      std::string export_path;
      bool json = false;
      SkeletonParams params;
      InputOptions input_options;
    };
    auto o = std::make_shared<Opts>();
    sub.add_option("SKELETON", o->input, "Skeleton file (.json, .swc; QSM .mat, .csv, .txt; .mtg)")->required();
    sub.add_option("--export", o->export_path, "Also write the sanitized skeleton as JSON to this file");
    sub.add_flag("--json", o->json, "Print the report as JSON");
    add_skeleton_options(sub, o->params);
    add_input_options(sub, o->input_options);
    return [o] {
      if (!o->export_path.empty()) check_json_output(o->export_path, "--export");
      const SkeletonResult result = load_skeleton(o->input, o->params, read_options(o->input_options));
      if (o->json) {
        const auto& r = result.report;
        const Skeleton& s = result.skeleton;
        std::size_t tips = 0, forks = 0;
        for (std::size_t i = 0; i < s.size(); ++i) {
          tips += s.is_tip(NodeId(i));
          forks += s.is_fork(NodeId(i));
        }
        nlohmann::json j{{"nodes", s.size()},
                         {"input_nodes", r.input_nodes},
                         {"tips", tips},
                         {"forks", forks},
                         {"merged_edges", r.merged_edges},
                         {"raised_radii", r.raised_radii},
                         {"radius_floor", r.radius_floor},
                         {"clamped_children", r.clamped_children},
                         {"resampled_edges", r.resampled_edges},
                         {"binarized_nodes", r.binarized_nodes},
                         {"inserted_nodes", r.inserted_nodes},
                         {"merged_inner", r.merged_inner},
                         {"hairpins", r.hairpins},
                         {"hidden_tips", r.hidden_tips},
                         {"tight_bends", r.tight_bends},
                         {"collars", r.collars},
                         {"raised_laterals", r.raised_laterals},
                         {"branch_collisions", r.branch_collisions},
                         {"unresolved_collisions", r.unresolved_collisions},
                         {"max_separation", r.max_separation},
                         {"dropped_nodes", r.dropped_nodes},
                         {"max_move", r.max_move},
                         {"max_move_radii", r.max_move_radii},
                         {"p95_move_radii", r.p95_move_radii}};
        std::printf("%s\n", j.dump(2).c_str());
      } else {
        std::printf("%s\n%s", o->input.c_str(), describe_skeleton(result).c_str());
      }
      if (!o->export_path.empty()) write_skeleton_json(result.skeleton, o->export_path, o->input);
      return int(kOk);
    };
  });
}

}  // namespace sm::cli
