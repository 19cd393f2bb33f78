// strandmesh mesh SKELETON -o OUT: the whole pipeline, one command.

#include <cstdio>
#include <mutex>
#include <optional>
#include <utility>

#include "apps/cli/commands.h"
#include "apps/cli/param_help.h"
#include "apps/cli/export_options.h"
#include "apps/cli/input_options.h"
#include "apps/cli/skeleton_options.h"
#include "core/errors.h"
#include "core/file_io.h"
#include "core/log.h"
#include "meshcheck/checks.h"
#include "meshio/export.h"
#include "lod/lod.h"
#include "pipeline/pipeline.h"
#include "skeleton/io.h"

namespace sm::cli {

namespace {
// The file of level of detail k: "tree.glb" -> "tree_lod1.glb".
std::string lod_path(const std::string& output, std::uint32_t k) {
  const std::filesystem::path p(output);
  return (p.parent_path() / (p.stem().string() + "_lod" + std::to_string(k) + p.extension().string())).string();
}
}  // namespace

void add_mesh_command(CLI::App& app, const GlobalOptions& global) {
  add_command(app, "mesh", "Mesh a skeleton: strandmesh mesh SKELETON -o OUT.{glb,gltf,obj,ply}", [&global](CLI::App& sub) -> Action {
    struct Opts {
      std::string input, output, config, dump_dir, stats_path, output_format = "glb";
      std::uint64_t seed = 1;
      double spacing = 0;
      std::uint32_t root_strands = 0;
      bool print_config = false;
      bool strict = false;
      SkeletonParams skeleton;
      InputOptions input_options;
      ExportOptions export_options;
    };
    auto o = std::make_shared<Opts>();
    // Required unless --print-config (checked below, so the config can be printed alone).
    sub.add_option("SKELETON", o->input, "Skeleton file (.json, .swc; QSM .mat, .csv, .txt; .mtg), or - for standard input (JSON or SWC); required");
    sub.add_option("-o,--output", o->output, "Output mesh: .glb, .gltf, .obj or .ply, or - for standard output (see --output-format); required");
    sub.add_option("--output-format", o->output_format, "Format written to standard output (-o -): glb, gltf, obj or ply")
        ->check(CLI::IsMember({"glb", "gltf", "obj", "ply"}))
        ->capture_default_str();
    sub.add_option("--config", o->config, "Parameter file (JSON; every key: mesh --print-config; see configs/ and docs/pipeline.md)");
    auto* seed = sub.add_option("--seed", o->seed, param_help<ParticleParams>("seed"))
                     ->capture_default_str()
                     ->check(kNotNegative);
    auto* spacing = sub.add_option("--spacing", o->spacing, param_help<ParticleParams>("spacing"))
                        ->check(CLI::NonNegativeNumber);
    auto* root = sub.add_option("--root-strands", o->root_strands, param_help<ParticleParams>("root_strands"))
                     ->check(CLI::Range(1.0, double(ParticleParams::kMaxRootStrands)));
    sub.add_option("--dump-stages", o->dump_dir, "Also write every stage's result as JSON into this directory");
    sub.add_option("--stats", o->stats_path, "Write the run's figures (counts, seconds per stage) as JSON");
    sub.add_flag("--print-config", o->print_config, "Print the full parameter set as a config file and exit");
    sub.add_flag("--strict", o->strict,
                 "Also run `strandmesh check` on the mesh (against the input skeleton, as `check --skeleton`) and exit 4 when it fails a check "
                 "(the outputs are written all the same)");
    add_skeleton_options(sub, o->skeleton);
    add_input_options(sub, o->input_options);
    add_export_options(sub, o->export_options);
    // Which skeleton options were given explicitly (they override the config file).
    std::vector<CLI::Option*> skeleton_opts;
    for (const char* name : {"--max-nodes", "--merge-edge-ratio", "--radius-floor", "--thick-child", "--max-child-ratio",
                             "--max-edge-ratio", "--keep-input", "--separate"}) {
      skeleton_opts.push_back(sub.get_option(name));
    }
    return [o, seed, spacing, root, skeleton_opts, &global] {
      Stopwatch total;
      PipelineParams params;
      if (!o->config.empty()) params = load_params(o->config);
      if (seed->count() > 0) params.particles.seed = o->seed;
      if (spacing->count() > 0) params.particles.spacing = o->spacing;
      if (root->count() > 0) params.particles.root_strands = o->root_strands;
      // Explicit skeleton flags override the config file field by field.
      const SkeletonParams defaults{};
      const SkeletonParams& cli = o->skeleton;
      if (skeleton_opts[0]->count()) params.skeleton.max_nodes = cli.max_nodes;
      if (skeleton_opts[1]->count()) params.skeleton.merge_edge_ratio = cli.merge_edge_ratio;
      if (skeleton_opts[2]->count()) params.skeleton.radius_floor = cli.radius_floor;
      if (skeleton_opts[3]->count()) params.skeleton.thick_child_policy = cli.thick_child_policy;
      if (skeleton_opts[4]->count()) params.skeleton.max_child_ratio = cli.max_child_ratio;
      if (skeleton_opts[5]->count()) params.skeleton.max_edge_ratio = cli.max_edge_ratio;
      if (skeleton_opts[6]->count() || skeleton_opts[7]->count()) params.skeleton.separate = cli.separate;
      (void)defaults;
      apply_export_options(o->export_options, params.output);
      if (o->print_config) {
        std::fputs(params_to_json(params).c_str(), stdout);
        return int(kOk);
      }
      if (o->input.empty() || o->output.empty()) {
        log::error(std::string(o->input.empty() ? "SKELETON" : "--output") +
                   " is required (strandmesh mesh SKELETON -o OUT.{glb,gltf,obj,ply}; see --help)");
        return int(kUsage);
      }
      // Every output is checked before the long run (an unknown extension, a missing or
      // read-only folder, a target that is a directory or device), and all are written
      // together at the end, or none of them (OutputTransaction).
      const bool to_stdout = o->output == "-";
      const MeshFormat format = mesh_format_from_path(to_stdout ? "stdout." + o->output_format : o->output);
      if (!o->stats_path.empty() && extension_of(o->stats_path) != "json") {
        throw InvalidInputError(o->stats_path + ": --stats writes JSON; the file name must end in .json");
      }
      struct RemoveCreatedDir {  // a dump folder this run created is removed again on failure (when empty)
        std::string dir;
        ~RemoveCreatedDir() {
          std::error_code ec;
          if (!dir.empty()) std::filesystem::remove(dir, ec);  // only removes an empty folder
        }
      } created;
      if (!o->dump_dir.empty()) {  // first: it may also receive the mesh or the stats
        check_output_dir(o->dump_dir);
        std::error_code ec;
        if (std::filesystem::create_directories(o->dump_dir, ec)) created.dir = o->dump_dir;
        if (ec) throw IoError("cannot create directory " + o->dump_dir + ": " + ec.message());
      }
      if (!to_stdout) check_output_path(o->output);
      const std::uint32_t lods = params.output.lods;
      // glTF holds every level in one file (MSFT_lod) unless --lod-files; OBJ and PLY cannot.
      const bool one_file =
          lods > 1 && !params.output.lod_files && (format == MeshFormat::glb || format == MeshFormat::gltf);
      if (lods > 1 && !one_file && to_stdout) {
        throw UsageError("levels of detail in files of their own (--lod-files, or OBJ and PLY) cannot go to standard output");
      }
      if (!one_file) {
        for (std::uint32_t k = 1; k < lods; ++k) check_output_path(lod_path(o->output, k));
      }
      if (!o->stats_path.empty()) check_output_path(o->stats_path);
      OutputTransaction outputs;
      const RawSkeleton raw = read_skeleton_arg(o->input, read_options(o->input_options));
      ProgressBar bar(!global.quiet, OverallProgress::pipeline());
      std::mutex m;
      PipelineResult r = run_pipeline(raw, params, [&](std::string_view phase, double f) {
        std::lock_guard lock(m);
        bar.update(phase, f);
      });
      if (!o->dump_dir.empty()) dump_stages(r, o->dump_dir);  // creates the folder, which may hold the output
      release_intermediates(r);  // their memory goes to the exporter
      Stopwatch export_clock;
      ExportParams ep = params.output;
      ep.up_axis = r.skeleton.skeleton.up_axis;
      ep.root = r.skeleton.skeleton.position[0];
      ep.skeleton = &r.skeleton.skeleton;  // for the tree attributes
      // Streamed: the file is never held whole in memory; the bar goes on through it. With the
      // levels of detail in one file, it is written once they are all made.
      std::string mesh_bytes;  // for standard output, written once everything succeeded
      if (one_file) {
      } else if (to_stdout) {
        mesh_bytes = encode_mesh(r.mesh.mesh, format, ep);
      } else {
        write_mesh(r.mesh.mesh, o->output, ep, [&](std::string_view phase, double f) { bar.update(phase, f); });
      }
      double export_seconds = export_clock.elapsed();
      bar.finish();
      print_warnings(r.warnings(), global.verbose, raw.grown ? kExpectedOfGrownTrees : std::set<std::string>{});
      if (r.mesh.stats.bad_edges > 0) {
        log::error("internal error: the mesh has " + std::to_string(r.mesh.stats.bad_edges) +
                   " edges not shared by exactly two triangles; please report this skeleton");
        return int(kInternal);  // nothing written
      }
      // Levels of detail: the pipeline again on a pruned skeleton with coarser parameters (lod/lod.h).
      std::vector<std::string> lod_lines;
      std::vector<PipelineResult> levels;  // 1, 2, ...: each is made from the one before where it needs to be
      for (std::uint32_t k = 1; k < lods; ++k) {
        Stopwatch lod_clock;
        LodLevel level;
        ProgressBar lod_bar(!global.quiet, OverallProgress::pipeline());
        PipelineResult lr = mesh_lod(raw, params, k, {}, [&](std::string_view phase, double f) {
          std::lock_guard lock(m);
          lod_bar.update(phase, f);
        }, &level, levels.empty() ? &r : &levels.back());
        if (lr.mesh.stats.bad_edges > 0) {
          log::error("internal error: level of detail " + std::to_string(k) + " has " +
                     std::to_string(lr.mesh.stats.bad_edges) + " edges not shared by exactly two triangles");
          return int(kInternal);
        }
        const std::string file = one_file ? o->output + " (node tree_lod" + std::to_string(k) + ")" : lod_path(o->output, k);
        if (!one_file) {
          ExportParams lp = ep;
          lp.skeleton = &lr.skeleton.skeleton;  // the same root: the pivot does not move between levels
          write_mesh(lr.mesh.mesh, lod_path(o->output, k), lp, [&](std::string_view phase, double f) { lod_bar.update(phase, f); });
        }
        lod_bar.finish();
        char text[320];
        if (level.simplified) {
          std::snprintf(text, sizeof text,
                        "  level %u: %zu triangles (level %u simplified: the pipeline's run kept %zu self-intersecting "
                        "pairs) in %.2f s -> %s",
                        k, lr.mesh.mesh.triangle_count(), k - 1, level.rerun_pairs, lod_clock.elapsed(),
                        file.c_str());
        } else {
          std::snprintf(text, sizeof text,
                        "  level %u: %zu triangles (twigs under %.4g m pruned: %zu nodes; %u root strands, slice step "
                        "%.2g) in %.2f s -> %s",
                        k, lr.mesh.mesh.triangle_count(), level.min_radius, level.pruned,
                        level.params.particles.max_root_strands, level.params.contours.slice_step, lod_clock.elapsed(),
                        file.c_str());
        }
        if (level.pairs > 0) {
          log::warn("level of detail " + std::to_string(k) + " keeps " + std::to_string(level.pairs) +
                    " self-intersecting triangle pairs");
        }
        lod_lines.emplace_back(text);
        levels.push_back(std::move(lr));
      }
      if (one_file) {  // every level in one glTF file: MSFT_lod on level 0's node (meshio/export.h)
        Stopwatch clock;
        std::vector<ExportLevel> all{{&r.mesh.mesh, &r.skeleton.skeleton}};
        for (const PipelineResult& l : levels) all.push_back({&l.mesh.mesh, &l.skeleton.skeleton});
        if (to_stdout) {
          mesh_bytes = encode_mesh_levels(all, format, ep);
        } else {
          ProgressBar export_bar(!global.quiet);
          write_mesh_levels(all, o->output, ep, [&](std::string_view phase, double f) { export_bar.update(phase, f); });
          export_bar.finish();
        }
        export_seconds += clock.elapsed();
      }
      if (!o->stats_path.empty()) write_file_atomically(o->stats_path, stats_to_json(r, export_seconds, total.elapsed()));
      outputs.commit();
      if (to_stdout) {
        std::fwrite(mesh_bytes.data(), 1, mesh_bytes.size(), stdout);
        if (std::fflush(stdout) != 0) throw IoError("cannot write the mesh to standard output");
      }
      created.dir.clear();
      char line[512];
      std::snprintf(line, sizeof line, "%s: %zu nodes, %zu strands, %zu particles => %zu triangles, %zu vertices in %.2f s -> %s",
                    o->input.c_str(), r.skeleton.skeleton.size(), r.particles.strand_count(), r.particles.position.size(),
                    r.mesh.mesh.triangle_count(), r.mesh.mesh.vertex_count(), total.elapsed(), o->output.c_str());
      log::info(line);
      for (const std::string& l : lod_lines) log::info(l);
      if (r.repair.fork_retry.counted && !r.repair.fork_retry.counted_everywhere && global.verbose) {
        std::snprintf(line, sizeof line,
                      "note: self-intersections were looked for near the junctions only (%zu triangles, more than "
                      "repair.count_pairs_up_to = %zu): `strandmesh check` counts them all; a higher limit "
                      "(configs/high_detail.json) has them looked for and repaired everywhere (about 2x the time, up "
                      "to 7x where it repairs)",
                      r.mesh.mesh.triangle_count(), params.repair.count_pairs_up_to);
        log::verbose(line);
      }
      // Per stage, and the phases of the two costliest (contours, meshing) under them.
      for (const auto& [stage, phases] : stage_phases(r)) {
        std::snprintf(line, sizeof line, "  %-10s %8.3f s", stage, r.timings.get(stage));
        log::verbose(line);
        if (phases != nullptr) verbose_phases(*phases);
      }
      std::snprintf(line, sizeof line, "  %-10s %8.3f s", "export", export_seconds);
      log::verbose(line);
      if (const ForkRetryStats& fr = r.repair.fork_retry; fr.runs > 0) {
        log::verbose("  fork retry: " + to_text(fr) + " (its runs' times are the repair stage's)");
      }
      if (const NearMissStats& nm = r.repair.near_misses; nm.outside_before > 0) {
        log::verbose("  near misses: " + to_text(nm));
      }
      if (const OuterSurfaceStats& os = r.repair.outer_surface; os.tried) {
        log::verbose("  outer surface: " + to_text(os) + (os.refused.empty() ? "" : "; not kept: " + os.refused));
      }
      if (o->strict) {
        // As `strandmesh check --skeleton`: against the skeleton as the file gives it, never
        // against our own sanitized copy.
        const Skeleton input = input_skeleton(raw, params.skeleton);
        MeshCheckParams cp;
        cp.skeleton = &input;
        cp.implied_genus = true;
        const MeshCheckReport report = check_mesh(r.mesh.mesh, cp);
        if (!report.ok()) {
          log::error(o->output + " fails its checks (--strict):\n" + to_text(report));
          return int(kCheckFailed);
        }
      }
      return int(kOk);
    };
  });
}

}  // namespace sm::cli
