// `strandmesh batch`: the tree list, shards, records and summaries (batch/), the thumbnails,
// and the command end to end on a few small grown trees: the same bytes with --jobs 2 and
// with shards merged, resumption after a kill without redoing finished trees, a broken input
// reported while the others are meshed. The 200-tree runs through GNU parallel and Slurm are
// tests/batch/*.sh (labels slow and slurm).

#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <map>
#include <thread>

#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>

#include <stb/stb_image.h>

#include "batch/batch.h"
#include "batch/thumbnail.h"
#include "core/errors.h"
#include "core/file_io.h"
#include "meshio/mesh_io.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"
#include "tests/mesh_fixtures.h"

extern char** environ;

namespace sm {
namespace {

namespace fs = std::filesystem;
using test::CmdResult;

void touch(const fs::path& p, const std::string& text = "{}") { write_file_atomically(p, text); }

template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// --- the list of trees -------------------------------------------------------------------

TEST(BatchList, DirectoriesFilesAndUniqueNames) {
  const fs::path dir = test::temp_dir("batch_list");
  fs::create_directories(dir / "plot");
  for (const char* f : {"b.json", "a.json", "a.csv", "cyl_data_a.txt", "notes.txt", ".hidden.json", "x.glb"})
    touch(dir / "plot" / f);
  touch(dir / "a.json");
  const auto trees = batch::list_trees({(dir / "plot").string(), (dir / "a.json").string()}, {});
  std::vector<std::string> names;
  for (const auto& t : trees) names.push_back(t.name);
  // Sorted by file name, the explicit file last; a second "a" gets its extension, a third a number.
  EXPECT_EQ(names, (std::vector<std::string>{"a", "a_json", "b", "cyl_data_a", "a_json_2"}));
  for (std::size_t i = 0; i < trees.size(); ++i) EXPECT_EQ(trees[i].index, i);
  EXPECT_NE(error_of([&] { batch::list_trees({(dir / "missing.json").string()}, {}); }).find("missing.json"),
            std::string::npos);
  EXPECT_THROW(batch::list_trees({}, {}), UsageError);
}

TEST(BatchList, ManifestEntriesWithTheirOwnOptions) {
  const fs::path dir = test::temp_dir("batch_manifest");
  touch(dir / "cfg.json", R"({"particles": {"seed": 3}})");
  touch(dir / "trees.json", R"({"trees": [
      "t1.json",
      {"input": "sub/t2.mtg", "name": "walnut", "units": "mm,0.1mm", "config": "cfg.json", "offset": [10, 20, 0]},
      {"input": "t3.csv", "columns": "radius=r", "format": "table", "config": {"repair": {"outer_surface": false}}}]})");
  const auto trees = batch::list_trees({(dir / "trees.json").string()}, {});
  ASSERT_EQ(trees.size(), 3u);
  EXPECT_EQ(trees[0].input, dir / "t1.json");
  EXPECT_EQ(trees[1].name, "walnut");
  EXPECT_EQ(trees[1].input, dir / "sub/t2.mtg");
  EXPECT_DOUBLE_EQ(trees[1].read.length_unit, 0.001);
  EXPECT_DOUBLE_EQ(trees[1].read.thickness_unit, 0.0001);
  EXPECT_EQ(trees[1].config["particles"]["seed"], 3);
  EXPECT_EQ(trees[1].offset, dvec3(10, 20, 0));
  EXPECT_EQ(trees[2].read.format, SkeletonFormat::table);
  EXPECT_EQ(trees[2].read.columns.at(0).second, "r");
  EXPECT_EQ(trees[2].config["repair"]["outer_surface"], false);

  const std::pair<const char*, const char*> bad[] = {
      {R"({"trees": [{"input": "a.json", "colour": "red"}]})", "trees[0]: unknown key \"colour\""},
      {R"({"trees": [{"name": "x"}]})", "trees[0]: missing \"input\""},
      {R"({"trees": ["a.json", {"input": "b.json", "offset": [1, 2]}]})", "trees[1]: \"offset\" must be [x, y, z]"},
      {R"({"trees": [{"input": "a.json", "units": "furlong"}]})", "trees[0]: --units furlong"},
      {R"({"trees": [{"input": "a.json", "config": 7}]})", "trees[0]: \"config\" must be a file name or an object"},
      {R"({"trees": {"input": "a.json"}})", "\"trees\" must be an array"},
  };
  for (const auto& [text, message] : bad) {
    touch(dir / "bad.json", text);
    const std::string e = error_of([&] { batch::list_trees({(dir / "bad.json").string()}, {}); });
    EXPECT_NE(e.find(message), std::string::npos) << e;
    EXPECT_NE(e.find("bad.json"), std::string::npos) << e;
  }
}

TEST(BatchList, ShardsSplitRoundRobin) {
  EXPECT_EQ(batch::parse_shard("2/4").index, 2u);
  EXPECT_EQ(batch::parse_shard("2/4").count, 4u);
  for (const char* bad : {"4/4", "1", "a/2", "1/0", "-1/3", "1/2x"}) EXPECT_THROW(batch::parse_shard(bad), UsageError) << bad;
  std::vector<batch::TreeJob> trees(7);
  for (std::size_t i = 0; i < trees.size(); ++i) trees[i].index = i;
  std::vector<std::size_t> seen;
  for (std::size_t s = 0; s < 3; ++s)
    for (const auto& t : batch::take_shard(trees, {s, 3})) seen.push_back(t.index);
  EXPECT_EQ(seen, (std::vector<std::size_t>{0, 3, 6, 1, 4, 2, 5}));  // each tree in exactly one shard
}

TEST(BatchRecords, RoundTripSummaryAndMerge) {
  const fs::path dir = test::temp_dir("batch_records");
  EXPECT_EQ(batch::hash_hex("abc"), "e71fa2190541574b");  // FNV-1a 64, fixed forever
  std::vector<batch::TreeRecord> records(3);
  for (std::size_t i = 0; i < 3; ++i) {
    batch::TreeRecord& r = records[i];
    r.index = i;
    r.name = "t" + std::to_string(i);
    r.input = "in/t" + std::to_string(i) + ".json";
    r.status = i == 1 ? "failed" : "ok";
    r.error = i == 1 ? "in/t1.json:2:1: not valid JSON, \"quoted\"" : "";
    r.mesh = i == 1 ? "" : r.name + ".glb";
    r.figures = {{"mesh", {{"triangles", 100 * i}}}, {"checks", {{"closed", true}, {"fidelity_p95", 0.0612345}}}};
    write_file_atomically(dir / batch::record_file(r.name), batch::record_to_json(r));
    const auto back = batch::read_record(dir / batch::record_file(r.name));
    ASSERT_TRUE(back.has_value());
    EXPECT_EQ(batch::record_to_json(*back), batch::record_to_json(r));
  }
  const std::string csv = batch::summary_csv(records);
  EXPECT_NE(csv.find("\n1,t1,in/t1.json,failed,"), std::string::npos);
  EXPECT_NE(csv.find("\"in/t1.json:2:1: not valid JSON, \"\"quoted\"\"\""), std::string::npos);  // CSV quoting
  EXPECT_NE(csv.find(",yes,"), std::string::npos);
  EXPECT_NE(csv.find(",0.06123,"), std::string::npos);
  const auto rows = batch::summary_rows(csv, "s.csv");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[2], std::make_pair(std::size_t(2), std::string("t2")));
  EXPECT_NE(batch::summary_html(records, "plot <1>").find("plot &lt;1&gt;"), std::string::npos);

  // Shards 0 and 2 of 3 written, shard 1 missing: the merge names it; with it, the merge gives
  // the summary of the whole list.
  fs::create_directories(dir / "shards");
  write_file_atomically(batch::shard_summary_path(dir, {0, 3}), batch::summary_csv({records[0]}));
  write_file_atomically(batch::shard_summary_path(dir, {2, 3}), batch::summary_csv({records[2]}));
  EXPECT_NE(error_of([&] { batch::merge_shards(dir, "t"); }).find("shard 1 of 3 missing"), std::string::npos);
  write_file_atomically(batch::shard_summary_path(dir, {1, 3}), batch::summary_csv({records[1]}));
  EXPECT_EQ(batch::merge_shards(dir, "t").size(), 3u);
  EXPECT_EQ(read_file(dir / "summary.csv"), csv);
  write_file_atomically(batch::shard_summary_path(dir, {0, 2}), batch::summary_csv({records[0]}));
  EXPECT_NE(error_of([&] { batch::merge_shards(dir, "t"); }).find("different runs"), std::string::npos);
}

// --- thumbnails --------------------------------------------------------------------------

TEST(Thumbnail, ShowsTheMeshOnWhiteAndIsDeterministic) {
  const Mesh box = test::box();
  ThumbnailParams p;
  p.size = 64;
  const std::string png = render_thumbnail_png(box, UpAxis::z, p);
  EXPECT_EQ(png, render_thumbnail_png(box, UpAxis::z, p));
  int w = 0, h = 0, c = 0;
  unsigned char* px = stbi_load_from_memory(reinterpret_cast<const unsigned char*>(png.data()), int(png.size()), &w, &h, &c, 3);
  ASSERT_NE(px, nullptr);
  EXPECT_EQ(w, 64);
  EXPECT_EQ(h, 64);
  auto at = [&](int x, int y) { return px + 3 * (y * w + x); };
  EXPECT_EQ(at(1, 1)[0], 255);     // background
  EXPECT_LT(at(32, 32)[0], 250);   // the cube fills the middle
  stbi_image_free(px);
  EXPECT_FALSE(render_thumbnail_png(Mesh{}, UpAxis::z, p).empty());  // blank, not an error
  p.size = 4;
  EXPECT_THROW(render_thumbnail_png(box, UpAxis::z, p), InvalidInputError);
}

// --- the command -------------------------------------------------------------------------

/// Every regular, non-hidden file under `dir` (shards/ aside) and its bytes.
std::map<std::string, std::string> outputs(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (e.is_regular_file() && name[0] != '.') files[name] = read_file(e.path());
  }
  return files;
}

struct Forest {
  fs::path dir, inputs, config;
  std::string args;  ///< the inputs and options every run shares
};

/// Four small grown trees, a broken file and a manifest moving one more tree, meshed with
/// coarse settings.
Forest small_forest(const std::string& name) {
  Forest f;
  f.dir = test::temp_dir(name);
  f.inputs = f.dir / "in";
  fs::create_directories(f.inputs);
  for (int seed = 1; seed <= 4; ++seed) {
    write_file_atomically(f.inputs / ("tree" + std::to_string(seed) + ".json"), raw_skeleton_to_json(test::grown_tree(seed)));
  }
  touch(f.inputs / "broken.json", "{\"nodes\": [{\"id\": 0, \"parent\": -1, \"position\": [0, 0,\n");
  write_file_atomically(f.dir / "moved.json", raw_skeleton_to_json(test::grown_tree(5)));
  touch(f.dir / "plot.json", R"({"trees": [{"input": "moved.json", "name": "moved", "offset": [100, 200, 0],
                                           "config": {"particles": {"seed": 2}}}]})");
  f.config = fs::path(STRANDMESH_SOURCE_DIR) / "configs/preview.json";
  f.args = f.inputs.string() + " " + (f.dir / "plot.json").string() + " --config " + f.config.string();
  return f;
}

TEST(BatchCli, JobsAndShardsGiveTheSameBytes) {
  const Forest f = small_forest("batch_cli_same");
  const CmdResult a = test::run_cli("batch " + f.args + " -q --jobs 2 -o " + (f.dir / "a").string());
  EXPECT_EQ(a.code, 5) << a.err;  // some failed: the broken file
  EXPECT_NE(a.err.find("broken: failed: " + (f.inputs / "broken.json").string() + ":2:"), std::string::npos) << a.err;
  const auto out = outputs(f.dir / "a");
  for (const char* file : {"tree1.glb", "tree4.png", "moved.stats.json", "broken.stats.json", "summary.csv", "index.html"})
    EXPECT_EQ(out.count(file), 1u) << file;
  EXPECT_EQ(out.count("broken.glb"), 0u);
  const std::string& csv = out.at("summary.csv");
  EXPECT_NE(csv.find(",broken," + (f.inputs / "broken.json").string() + ",failed,"), std::string::npos) << csv;
  for (const char* t : {"tree1", "tree2", "tree3", "tree4", "moved"}) {
    const auto rec = batch::read_record(f.dir / "a" / batch::record_file(t));
    ASSERT_TRUE(rec.has_value()) << t;
    EXPECT_EQ(rec->status, "ok") << t << ": " << rec->error;
    EXPECT_EQ(rec->figures["checks"]["closed"], true);
  }
  EXPECT_NE(out.at("index.html").find("<img src=\"tree3.png\""), std::string::npos);
  // The manifest's offset moved the tree (meshes keep the input's coordinates otherwise).
  const Mesh moved = read_mesh(f.dir / "a/moved.glb");
  dvec3 lo(1e300);
  for (const dvec3& p : moved.positions) lo = glm::min(lo, p);
  EXPECT_GT(lo.x, 90.0);
  EXPECT_GT(lo.y, 190.0);

  // Two shards (in either order) and a merge: the same files, byte for byte.
  for (const char* shard : {"1/2", "0/2"}) {
    const CmdResult s = test::run_cli("batch " + f.args + " -q --shard " + shard + " -o " + (f.dir / "b").string());
    EXPECT_TRUE(s.code == 0 || s.code == 5) << s.err;
  }
  EXPECT_FALSE(fs::exists(f.dir / "b/summary.csv"));  // a shard writes only its own summary
  const CmdResult m = test::run_cli("batch --merge -o " + (f.dir / "b").string());
  EXPECT_EQ(m.code, 5) << m.err;
  EXPECT_EQ(outputs(f.dir / "b"), out);
}

TEST(BatchCli, KilledRunResumesWithoutRedoingFinishedTrees) {
  const Forest f = small_forest("batch_cli_resume");
  const fs::path out = f.dir / "out";
  // Start a run, one tree at a time, and kill it (SIGKILL: no clean-up) once two trees are done.
  const std::string exe = std::string(STRANDMESH_BINARY_DIR) + "/strandmesh";
  std::vector<std::string> args{exe, "batch", f.inputs.string(), (f.dir / "plot.json").string(), "--config",
                                f.config.string(), "-q", "--jobs", "1", "-o", out.string()};
  std::vector<char*> argv;
  for (std::string& s : args) argv.push_back(s.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  posix_spawn_file_actions_t quiet;  // the broken file's error line is expected: keep it out of the test log
  posix_spawn_file_actions_init(&quiet);
  posix_spawn_file_actions_addopen(&quiet, 2, "/dev/null", O_WRONLY, 0);
  ASSERT_EQ(posix_spawn(&pid, exe.c_str(), &quiet, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&quiet);
  auto done = [&] {
    std::size_t n = 0;
    for (const char* t : {"broken", "tree1", "tree2", "tree3", "tree4", "moved"}) n += fs::exists(out / batch::record_file(t));
    return n;
  };
  int status = 0;
  bool exited = false;
  while (done() < 3) {  // broken.json fails at once; then two trees
    if (waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  if (!exited) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
  ASSERT_FALSE(exited) << "the run finished before it could be killed";
  // What was finished at the kill, with the meshes' modification times.
  std::map<std::string, fs::file_time_type> finished;
  for (const char* t : {"tree1", "tree2", "tree3", "tree4", "moved"}) {
    if (fs::exists(out / batch::record_file(t))) finished[t] = fs::last_write_time(out / (std::string(t) + ".glb"));
  }
  ASSERT_GE(finished.size(), 2u);
  ASSERT_LT(finished.size(), 5u);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));  // a rewrite would show in the times
  const CmdResult resumed = test::run_cli("batch " + f.args + " -o " + out.string() + " -v");
  EXPECT_EQ(resumed.code, 5) << resumed.err;
  for (const auto& [t, time] : finished) {
    EXPECT_NE(resumed.err.find(t + ": ok (done before"), std::string::npos) << resumed.err;
    EXPECT_EQ(fs::last_write_time(out / (t + ".glb")), time) << t << " was meshed again";
  }
  EXPECT_NE(resumed.err.find("(" + std::to_string(finished.size()) + " done before)"), std::string::npos) << resumed.err;
  // And the result is that of an uninterrupted run.
  const CmdResult whole = test::run_cli("batch " + f.args + " -q -o " + (f.dir / "whole").string());
  EXPECT_EQ(whole.code, 5);
  EXPECT_EQ(outputs(out), outputs(f.dir / "whole"));
}

TEST(BatchCli, ChangedInputsAreMeshedAgainAndExitCodesCount) {
  const fs::path dir = test::temp_dir("batch_cli_codes");
  const std::string config = " --config " + (fs::path(STRANDMESH_SOURCE_DIR) / "configs/preview.json").string() + " -q";
  write_file_atomically(dir / "t.json", raw_skeleton_to_json(test::grown_tree(1)));
  EXPECT_EQ(test::run_cli("batch " + (dir / "t.json").string() + config + " -o " + (dir / "o").string()).code, 0);
  const std::string before = read_file(dir / "o/t.stats.json");
  // A different tree under the same name, then a different configuration: meshed again.
  write_file_atomically(dir / "t.json", raw_skeleton_to_json(test::grown_tree(2)));
  const CmdResult again = test::run_cli("batch " + (dir / "t.json").string() + config + " -v -o " + (dir / "o").string());
  EXPECT_EQ(again.code, 0);
  EXPECT_EQ(again.err.find("done before"), std::string::npos) << again.err;
  EXPECT_NE(read_file(dir / "o/t.stats.json"), before);
  const CmdResult other = test::run_cli("batch " + (dir / "t.json").string() + config + " --no-thumbnails -v -o " +
                                        (dir / "o").string());
  EXPECT_EQ(other.err.find("done before"), std::string::npos) << other.err;
  // A broken tree replacing it: failed, exit 6 (none succeeded), no stale mesh left.
  touch(dir / "t.json", "{\"nodes\": 3}");
  const CmdResult none = test::run_cli("batch " + (dir / "t.json").string() + config + " -o " + (dir / "o").string());
  EXPECT_EQ(none.code, 6) << none.err;
  EXPECT_FALSE(fs::exists(dir / "o/t.glb"));
  EXPECT_NE(read_file(dir / "o/summary.csv").find("must be an array"), std::string::npos);
  // Usage: no -o, a bad shard, outputs that would overwrite an input.
  EXPECT_EQ(test::run_cli("batch " + (dir / "t.json").string()).code, 2);
  EXPECT_EQ(test::run_cli("batch " + (dir / "t.json").string() + " --shard 2/2 -o " + (dir / "o").string()).code, 2);
  touch(dir / "plot.json", R"({"trees": [{"input": "x.stats.json", "name": "x"}]})");
  touch(dir / "x.stats.json", "{}");
  const CmdResult clash = test::run_cli("batch " + (dir / "plot.json").string() + " -o " + dir.string());
  EXPECT_EQ(clash.code, 2);
  EXPECT_NE(clash.err.find("would overwrite an input"), std::string::npos) << clash.err;
}

}  // namespace
}  // namespace sm
