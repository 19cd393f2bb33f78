// strandmesh batch INPUTS... -o OUTDIR: many trees in one resumable run (batch/batch.h,
// docs/batch.md). Trees run `--jobs` at a time; one that fails is recorded and the others go on.

#include <atomic>
#include <cstdio>
#include <mutex>
#include <set>
#include <thread>

#include "apps/cli/commands.h"
#include "apps/cli/input_options.h"
#include "batch/batch.h"
#include "batch/thumbnail.h"
#include "core/errors.h"
#include "core/file_io.h"
#include "core/log.h"
#include "meshcheck/checks.h"
#include "meshio/export.h"
#include "pipeline/pipeline.h"
#include "skeleton/io.h"

namespace sm::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using batch::TreeJob;
using batch::TreeRecord;

/// Batch exit codes beside the common ones (cli.h): some trees failed, or all of them.
constexpr int kSomeFailed = 5;
constexpr int kAllFailed = 6;

struct Settings {
  fs::path outdir;
  PipelineParams params;         ///< the batch's parameters (--config), before per-tree overrides
  std::string mesh_format = "glb";
  bool checks = true;
  bool thumbnails = true;
  bool strict = true;
  bool force = false;
  ThumbnailParams thumbnail;
};

std::string read_options_text(const ReadOptions& r) {
  std::string s = "format=" + format_name(r.format);
  for (const auto& [k, v] : r.columns) s += ";column " + k + "=" + v;
  char buf[96];
  std::snprintf(buf, sizeof buf, ";units=%.17g,%.17g", r.length_unit, r.thickness_unit);
  return s + buf;
}

/// The checks' figures kept in the record: every one that decides ok(), none of the timings.
json check_figures(const MeshCheckReport& c) {
  json j{{"ok", c.ok()},
         {"closed", c.closed},
         {"manifold", c.edge_manifold && c.vertex_manifold},
         {"oriented", c.oriented},
         {"components", c.components},
         {"degenerate_triangles", c.degenerate_triangles},
         {"volume", c.signed_volume}};
  if (c.genus) j["genus"] = *c.genus;
  if (c.self_intersections_checked) j["self_intersecting_pairs"] = c.self_intersecting_pairs;
  if (c.fidelity_checked) {
    j["fidelity_p50"] = c.fidelity_p50;
    j["fidelity_p95"] = c.fidelity_p95;
    j["fidelity_max"] = c.fidelity_max;
  }
  if (c.inside_checked) {
    j["thick_nodes"] = c.thick_nodes;
    j["thick_nodes_inside"] = c.thick_nodes_inside;
  }
  return j;
}

/// Meshes one tree (or finds it done) and writes its outputs and record. Never throws for the
/// tree's own faults: they become a "failed" record.
TreeRecord run_tree(const TreeJob& job, const Settings& s, bool& resumed) {
  resumed = false;
  TreeRecord rec;
  rec.index = job.index;
  rec.name = job.name;
  rec.input = job.input.string();
  rec.figures = json::object();
  const fs::path record_path = s.outdir / batch::record_file(job.name);
  const std::string mesh_name = job.name + "." + s.mesh_format;
  const std::string thumb_name = s.thumbnails ? batch::thumbnail_file(job.name) : std::string();
  std::error_code ec;
  try {
    const std::string bytes = read_file(job.input);
    rec.input_hash = batch::hash_hex(bytes);
    PipelineParams params = s.params;
    if (!job.config.is_null()) params = parse_params_json(job.config.dump(), rec.input + " (per-tree config)", params);
    char offset[96];
    std::snprintf(offset, sizeof offset, "%.17g,%.17g,%.17g", job.offset.x, job.offset.y, job.offset.z);
    rec.config_hash = batch::hash_hex(std::string(STRANDMESH_VERSION) + "\n" + params_to_json(params) + "\n" +
                                      read_options_text(job.read) + "\noffset=" + offset + "\nmesh=" + s.mesh_format +
                                      "\nchecks=" + (s.checks ? "1" : "0") +
                                      "\nthumbnail=" + (s.thumbnails ? std::to_string(s.thumbnail.size) : "0"));
    if (!s.force) {
      const auto done = batch::read_record(record_path);
      if (done && done->status != "failed" && done->input_hash == rec.input_hash &&
          done->config_hash == rec.config_hash && done->index == rec.index && done->name == rec.name &&
          fs::is_regular_file(s.outdir / done->mesh, ec) &&
          (thumb_name.empty() || fs::is_regular_file(s.outdir / thumb_name, ec))) {
        resumed = true;
        TreeRecord kept = *done;
        if (kept.input != rec.input) {  // the same file, spelt differently this time
          kept.input = rec.input;
          write_file_atomically(record_path, batch::record_to_json(kept));
        }
        return kept;
      }
    }
    RawSkeleton raw = read_skeleton(job.input, job.read);
    if (job.offset != dvec3(0.0))
      for (dvec3& p : raw.position) p += job.offset;
    PipelineResult r = run_pipeline(raw, params);
    if (r.mesh.stats.bad_edges > 0) {
      throw InternalError("the mesh has " + std::to_string(r.mesh.stats.bad_edges) +
                          " edges not shared by exactly two triangles; please report this skeleton");
    }
    const Warnings warnings = r.warnings();
    json warning_list = json::array();
    for (const auto& w : warnings.list()) warning_list.push_back(w.message + " (" + std::to_string(w.count) + "x)");
    rec.figures["skeleton"] = {{"input_nodes", raw.size()},
                               {"nodes", r.skeleton.skeleton.size()},
                               {"up_axis", r.skeleton.skeleton.up_axis == UpAxis::y ? "y" : "z"}};
    rec.figures["mesh"] = {{"strands", r.particles.strand_count()},
                           {"particles", r.particles.position.size()},
                           {"vertices", r.mesh.mesh.vertex_count()},
                           {"triangles", r.mesh.mesh.triangle_count()}};
    rec.figures["warnings"] = std::move(warning_list);
    release_intermediates(r);
    ExportParams ep = params.output;  // the config's "export" section (docs/export.md)
    ep.up_axis = r.skeleton.skeleton.up_axis;
    ep.root = r.skeleton.skeleton.position[0];
    ep.skeleton = &r.skeleton.skeleton;  // for the tree attributes (export.attributes: wind, ...)
    write_mesh(r.mesh.mesh, s.outdir / mesh_name, ep);
    rec.mesh = mesh_name;
    rec.status = "ok";
    if (s.checks) {
      MeshCheckParams cp;
      cp.skeleton = &r.skeleton.skeleton;
      const MeshCheckReport report = check_mesh(r.mesh.mesh, cp);
      rec.figures["checks"] = check_figures(report);
      if (!report.ok()) {
        rec.status = "check_failed";
        for (const std::string& f : report.failures()) rec.error += (rec.error.empty() ? "" : "; ") + f;
      }
    }
    if (s.thumbnails) {
      write_file_atomically(s.outdir / thumb_name, render_thumbnail_png(r.mesh.mesh, ep.up_axis, s.thumbnail));
      rec.thumbnail = thumb_name;
    }
  } catch (const std::bad_alloc&) {
    rec.status = "failed";
    rec.error = "out of memory";
  } catch (const InternalError& e) {
    rec.status = "failed";
    rec.error = std::string("internal error: ") + e.what();
  } catch (const Error& e) {
    rec.status = "failed";
    rec.error = e.what();
  } catch (const std::exception& e) {
    rec.status = "failed";
    rec.error = std::string("internal error: ") + e.what();
  }
  if (rec.status == "failed") {
    // No stale mesh or picture of an earlier run may stand beside a failed record.
    fs::remove(s.outdir / mesh_name, ec);
    if (!thumb_name.empty()) fs::remove(s.outdir / thumb_name, ec);
    rec.mesh.clear();
    rec.thumbnail.clear();
    rec.figures = json::object();
  }
  write_file_atomically(record_path, batch::record_to_json(rec));
  return rec;
}

/// Outputs must never overwrite an input (a batch run with -o on the input folder).
void check_outputs_spare_inputs(const std::vector<TreeJob>& trees, const Settings& s) {
  std::set<fs::path> inputs;
  std::error_code ec;
  for (const TreeJob& t : trees) inputs.insert(fs::weakly_canonical(t.input, ec));
  for (const TreeJob& t : trees) {
    for (const std::string& f : {t.name + "." + s.mesh_format, batch::record_file(t.name), batch::thumbnail_file(t.name)}) {
      if (inputs.count(fs::weakly_canonical(s.outdir / f, ec)) != 0) {
        throw UsageError("batch: the output " + (s.outdir / f).string() + " would overwrite an input; choose another -o");
      }
    }
  }
}

int exit_code(const std::vector<TreeRecord>& records, bool strict) {
  std::size_t ok = 0;
  for (const TreeRecord& r : records) ok += r.succeeded(strict);
  return ok == records.size() ? int(kOk) : ok == 0 ? kAllFailed : kSomeFailed;
}

std::string counts(const std::vector<TreeRecord>& records) {
  std::size_t ok = 0, flawed = 0, failed = 0;
  for (const TreeRecord& r : records) {
    ok += r.status == "ok";
    flawed += r.status == "check_failed";
    failed += r.status == "failed";
  }
  return std::to_string(records.size()) + " trees: " + std::to_string(ok) + " ok, " + std::to_string(flawed) +
         " meshed but failing a check, " + std::to_string(failed) + " failed";
}

}  // namespace

void add_batch_command(CLI::App& app, const GlobalOptions& global) {
  add_command(app, "batch", "Mesh many trees: strandmesh batch INPUTS... -o OUTDIR (resumable, shardable)",
              [&global](CLI::App& sub) -> Action {
    struct Opts {
      std::vector<std::string> inputs;
      std::string outdir, config, shard, title = "strandmesh batch";
      std::size_t jobs = 1;
      std::string mesh_format = "glb";
      bool no_checks = false, no_thumbnails = false, no_strict = false, force = false, merge = false;
      int thumbnail_size = 256;
      InputOptions input_options;
    };
    auto o = std::make_shared<Opts>();
    sub.add_option("INPUTS", o->inputs,
                   "Skeleton files, directories (their skeleton files) or manifests ({\"trees\": [...]}, docs/batch.md)");
    sub.add_option("-o,--output", o->outdir, "Output directory (created): NAME.glb, NAME.png, NAME.stats.json, "
                                              "summary.csv, index.html; required");
    sub.add_option("--config", o->config, "Parameter file for every tree (a manifest entry's \"config\" overrides it)");
    sub.add_option("-j,--jobs", o->jobs, "Trees meshed at a time in this process")->capture_default_str()->check(CLI::PositiveNumber);
    sub.add_option("--shard", o->shard,
                   "Only shard I of N (0 <= I < N; every N-th tree from the I-th), e.g. "
                   "$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT; writes shards/I-of-N.csv for --merge");
    sub.add_flag("--merge", o->merge, "Merge the shard summaries of -o OUTDIR into summary.csv and index.html");
    sub.add_option("--mesh-format", o->mesh_format, "Mesh file format: glb, gltf, obj or ply")
        ->capture_default_str()
        ->check(CLI::IsMember({"glb", "gltf", "obj", "ply"}));
    sub.add_flag("--no-checks", o->no_checks, "Do not check the meshes (closed, manifold, self-intersections, fidelity)");
    sub.add_flag("--no-strict", o->no_strict, "Count a mesh that fails a check as a success in the exit code");
    sub.add_flag("--no-thumbnails", o->no_thumbnails, "Do not render NAME.png");
    sub.add_option("--thumbnail-size", o->thumbnail_size, "Thumbnail width and height in pixels")
        ->capture_default_str()
        ->check(CLI::Range(8, 1024));
    sub.add_flag("--force", o->force, "Mesh every tree again, even those whose outputs match their input and config");
    sub.add_option("--title", o->title, "Title of index.html")->capture_default_str();
    add_input_options(sub, o->input_options);
    sub.footer("Exit codes: 0 every tree succeeded, 5 some failed, 6 all failed (a mesh failing a check counts as "
               "failed unless --no-strict), 1 bad input (manifest, config, output folder), 2 usage error.");
    return [o, &global] {
      Stopwatch clock;
      if (o->outdir.empty()) throw UsageError("batch: -o OUTDIR is required");
      Settings s;
      s.outdir = o->outdir;
      if (o->merge) {
        if (!o->inputs.empty()) throw UsageError("batch --merge takes no inputs, only -o OUTDIR");
        check_output_dir(s.outdir);
        const std::vector<TreeRecord> records = batch::merge_shards(s.outdir, o->title);
        log::info("merged " + counts(records) + " -> " + (s.outdir / "index.html").string());
        return exit_code(records, !o->no_strict);
      }
      const batch::Shard shard = o->shard.empty() ? batch::Shard{} : batch::parse_shard(o->shard);
      if (!o->config.empty()) s.params = load_params(o->config);
      s.mesh_format = o->mesh_format;
      s.checks = !o->no_checks;
      s.thumbnails = !o->no_thumbnails;
      s.strict = !o->no_strict;
      s.force = o->force;
      s.thumbnail.size = o->thumbnail_size;
      const std::vector<TreeJob> all = batch::list_trees(o->inputs, read_options(o->input_options));
      const std::vector<TreeJob> trees = batch::take_shard(all, shard);
      check_output_dir(s.outdir);  // before any work: writable, or creatable in a writable folder
      std::error_code ec;
      fs::create_directories(s.outdir, ec);
      if (!fs::is_directory(s.outdir, ec)) throw IoError("cannot create the output directory " + s.outdir.string());
      check_outputs_spare_inputs(all, s);
      if (shard.count > 1) fs::create_directories(s.outdir / "shards", ec);

      std::vector<TreeRecord> records(trees.size());
      std::atomic<std::size_t> next{0}, finished{0}, resumed_count{0};
      std::mutex print;
      auto worker = [&] {
        for (std::size_t i = next++; i < trees.size(); i = next++) {
          Stopwatch tree_clock;
          bool resumed = false;
          records[i] = run_tree(trees[i], s, resumed);
          const TreeRecord& r = records[i];
          std::lock_guard lock(print);
          const std::size_t k = ++finished;
          resumed_count += resumed;
          char head[64];
          std::snprintf(head, sizeof head, "[%zu/%zu] ", k, trees.size());
          if (resumed) {
            log::verbose(head + r.name + ": " + r.status + " (done before, input and config unchanged)");
          } else if (r.status == "failed") {
            log::error(head + r.name + ": failed: " + r.error);  // shown even with --quiet
          } else {
            char line[256];
            const auto mesh = r.figures.find("mesh");
            const std::string triangles = mesh != r.figures.end() && mesh->contains("triangles") ? (*mesh)["triangles"].dump() : "?";
            std::snprintf(line, sizeof line, "%s: %s, %s triangles, %.2f s", r.name.c_str(), r.status.c_str(),
                          triangles.c_str(), tree_clock.elapsed());
            if (r.status == "ok") log::info(head + std::string(line));
            else log::warn(head + std::string(line) + ": " + r.error);
          }
        }
      };
      const std::size_t workers = std::min<std::size_t>(o->jobs, std::max<std::size_t>(trees.size(), 1));
      std::vector<std::thread> threads;
      for (std::size_t w = 1; w < workers; ++w) threads.emplace_back(worker);
      worker();
      for (std::thread& t : threads) t.join();

      if (shard.count > 1) {
        write_file_atomically(batch::shard_summary_path(s.outdir, shard), batch::summary_csv(records));
      } else {
        batch::write_summary(s.outdir, records, o->title);
      }
      const double seconds = clock.elapsed();
      char line[160];
      std::snprintf(line, sizeof line, " (%zu done before) in %.1f s, %.1f trees/min", resumed_count.load(), seconds,
                    seconds > 0 ? 60.0 * double(trees.size() - resumed_count) / seconds : 0.0);
      const std::string where = shard.count > 1 ? batch::shard_summary_path(s.outdir, shard).string() + " (merge with --merge)"
                                                : (s.outdir / "index.html").string();
      log::info((shard.count > 1 ? "shard " + o->shard + ": " : std::string()) + counts(records) + line + " -> " + where);
      (void)global;
      return exit_code(records, s.strict);
    };
  });
}

}  // namespace sm::cli
