// strandmesh check MESH [--skeleton SKELETON] [--json] [--no-self-intersections] [--quality-limits]
//
// Loads a mesh (.glb, .gltf, .obj, .ply), runs the mesh checks (meshcheck/checks.h) and the
// triangle quality figures (meshcheck/quality.h) and prints the report. Exit codes: 0 every check passed, 4 the mesh loaded but failed a check, 1 the
// mesh or skeleton file is unreadable or malformed, 2 usage error.

#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include "apps/cli/commands.h"
#include "apps/cli/input_options.h"
#include "core/log.h"
#include "meshcheck/checks.h"
#include "meshio/mesh_io.h"
#include "skeleton/build.h"
#include "skeleton/io.h"

namespace sm::cli {

void add_check_command(CLI::App& app, const GlobalOptions& global) {
  add_command(
      app, "check", "Check a mesh: closed, manifold, oriented, genus, self-intersections, skeleton fidelity",
      [&global](CLI::App& sub) -> Action {
        struct Opts {
          std::string mesh;
          std::string skeleton;
          bool json = false;
          bool no_self_intersections = false;
          bool quality_limits = false;
          double tolerance = MeshCheckParams{}.fidelity_tolerance;
          std::size_t examples = MeshCheckParams{}.max_examples;
          std::size_t worst = 0;
          std::uint32_t lod = 0;
          InputOptions input_options;  ///< how to read --skeleton
        };
        auto o = std::make_shared<Opts>();
        sub.add_option("MESH", o->mesh, "Mesh file (.glb, .gltf, .obj or .ply)")->required();
        sub.add_option("--skeleton", o->skeleton,
                       "Skeleton file (.json, .swc; QSM .mat, .csv, .txt; .mtg): also measure fidelity to its "
                       "radii, the input nodes inside and the genus its crossing branches imply; its up axis is "
                       "used to read the mesh");
        add_input_options(sub, o->input_options);
        sub.add_option("--lod", o->lod,
                       "Check level of detail K of a glTF file written with --lods (MSFT_lod; 0, the default, is the "
                       "full mesh)")
            ->check(CLI::Range(0, 7));
        sub.add_flag("--json", o->json, "Print the report as JSON");
        sub.add_flag("--no-self-intersections", o->no_self_intersections,
                     "Skip the self-intersection test (the slowest check)");
        sub.add_flag("--quality-limits", o->quality_limits,
                     "Fail (exit 4) where triangle quality misses the close-up goals: over 2 % of the triangles "
                     "with an angle under 10 degrees, any under 1 degree, a backward normal, a dihedral angle p99 "
                     "over 40 degrees at junctions (otherwise the quality figures are informative)");
        sub.add_option("--fidelity-tolerance", o->tolerance,
                       "Largest accepted 95th percentile of |distance to skeleton| / local radius")
            ->check(CLI::NonNegativeNumber)
            ->capture_default_str();
        sub.add_option("--examples", o->examples,
                       "Offending edges, triangle pairs and skeleton nodes listed per kind (a count)")
            ->capture_default_str()
            ->check(kNotNegative);
        sub.add_option("--worst", o->worst,
                       "With --skeleton: list the N vertices farthest from the skeleton's round cones, each with "
                       "the node at the upper end of its nearest edge (index in file order) and where along it")
            ->check(kNotNegative);
        sub.footer(
            "Exit codes: 0 all checks passed, 4 the mesh fails a check, 1 unreadable or malformed input,\n"
            "            2 usage error.");
        return [o, &global] {
          MeshCheckParams params{.self_intersections = !o->no_self_intersections,
                                 .fidelity_tolerance = o->tolerance,
                                 .max_examples = o->examples,
                                 .fidelity_worst = o->worst};
          if (o->quality_limits) params.quality_limits = QualityLimits{};
          MeshReadParams read;
          read.lod = o->lod;
          // Measured against the skeleton as the file gives it (radii below the floor raised
          // to it), never against our own sanitized copy.
          Skeleton skeleton;
          if (!o->skeleton.empty()) {
            skeleton = input_skeleton(read_skeleton(o->skeleton, read_options(o->input_options)));
            read.up_axis = skeleton.up_axis;
            params.skeleton = &skeleton;
            params.implied_genus = true;
            log::verbose(o->skeleton + ": " + std::to_string(skeleton.size()) + " input nodes");
          }
          const Mesh mesh = read_mesh(o->mesh, read);
          const MeshCheckReport report = check_mesh(mesh, params);
          if (o->json) {
            std::printf("%s\n", to_json(report).dump(2).c_str());
          } else {
            std::printf("%s\n%s", o->mesh.c_str(), to_text(report).c_str());
          }
          if (global.verbose) {
            for (const auto& t : report.timings.entries) {
              char buf[96];
              std::snprintf(buf, sizeof buf, "%-20s %.3f s", t.name.c_str(), t.seconds);
              log::verbose(buf);
            }
          }
          return report.ok() ? int(kOk) : int(kCheckFailed);
        };
      });
}

}  // namespace sm::cli
