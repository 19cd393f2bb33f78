// End-to-end tests of the strandmesh binary: exit codes, messages, no partial output.

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include "core/file_io.h"
#include "tests/fixtures.h"

namespace sm {
namespace {

namespace fs = std::filesystem;

using test::CmdResult;
CmdResult run(const std::string& args) { return test::run_cli(args); }

TEST(Cli, HelpAndVersion) {
  EXPECT_EQ(run("--help").code, 0);
  EXPECT_EQ(run("info --help").code, 0);
  EXPECT_EQ(run("grow --help").code, 0);
  EXPECT_NE(run("--version").out.find("strandmesh"), std::string::npos);
}

TEST(Cli, ExportFlagsTakeTheirHelpFromTheParameterTable) {
  // Each export parameter is described once, in meshio/param_table.cpp: every flag of the
  // export group names the config key whose help it prints.
  const CmdResult r = run("mesh --help");
  ASSERT_EQ(r.code, 0);
  for (const char* key : {"up_axis", "pivot", "scale", "attributes", "optimize", "compress", "lods", "lod_files",
                          "quantize"}) {
    EXPECT_NE(r.out.find(std::string("[config: export.") + key), std::string::npos) << key;
  }
  EXPECT_NE(r.out.find("MSFT_lod"), std::string::npos);
}

TEST(Cli, UsageErrorsExitTwo) {
  EXPECT_EQ(run("").code, 2);
  EXPECT_EQ(run("info").code, 2);
  EXPECT_EQ(run("info --no-such-option x.json").code, 2);
  EXPECT_EQ(run("frobnicate").code, 2);
  EXPECT_EQ(run("mesh").code, 2);
  EXPECT_EQ(run("mesh tree.json").code, 2);
  EXPECT_EQ(run("mesh -o out.glb").code, 2);
}

TEST(Cli, PrintConfigNeedsNoSkeleton) {
  // The printed config is the built-in default set, which configs/default.json spells out:
  // the same text after its description line (every key, no other, in the printed order, each
  // value written as printed: 1.0 is not 1), so neither can drift from the other.
  const CmdResult r = run("mesh --print-config");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string shipped = read_file(fs::path(STRANDMESH_SOURCE_DIR) / "configs/default.json");
  const std::string description = "\n  \"description\": ";
  const auto line = shipped.find(description);
  ASSERT_EQ(line, 1u) << "configs/default.json must start with its description";
  const std::string rest = shipped.substr(0, line + 1) + shipped.substr(shipped.find('\n', line + 1) + 1);
  EXPECT_EQ(rest, r.out) << "configs/default.json is out of date: run scripts/update_param_docs.sh";
  EXPECT_EQ(nlohmann::json::parse(shipped).size(), nlohmann::json::parse(r.out).size() + 1);
}

TEST(Cli, SkeletonFlagsOverrideTheConfig) {
  // --separate and --keep-input set skeleton.separate for `mesh` as for `info` (it was once
  // ignored there), over the config; the input is kept by default.
  const CmdResult r = run("mesh --separate --max-edge-ratio 2 --print-config");
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["skeleton"]["separate"], true);
  EXPECT_EQ(j["skeleton"]["max_edge_ratio"], 2.0);
  EXPECT_EQ(nlohmann::json::parse(run("mesh --print-config").out)["skeleton"]["separate"], false);
  const std::string separate = (fs::path(STRANDMESH_SOURCE_DIR) / "configs/separate.json").string();
  EXPECT_EQ(nlohmann::json::parse(run("mesh --config " + separate + " --keep-input --print-config").out)["skeleton"]["separate"],
            false);
}

TEST(Cli, ParamsReferenceInTheDocsIsCurrent) {
  // docs/defaults.md carries `strandmesh params --markdown` between its markers.
  const CmdResult r = run("params --markdown");
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string doc = read_file(fs::path(STRANDMESH_SOURCE_DIR) / "docs/defaults.md");
  const auto begin = doc.find("<!-- BEGIN strandmesh params --markdown");
  const auto end = doc.find("<!-- END strandmesh params --markdown");
  ASSERT_NE(begin, std::string::npos);
  ASSERT_NE(end, std::string::npos);
  const auto first = doc.find('\n', begin) + 1;
  EXPECT_EQ(doc.substr(first, end - first), r.out) << "docs/defaults.md is out of date: run scripts/update_param_docs.sh";
  // The skeleton flags take their help and range from the same table.
  const CmdResult flag = run("info --max-edge-ratio 0.5 tree.json");
  EXPECT_EQ(flag.code, 2);
  EXPECT_NE(flag.err.find("--max-edge-ratio: must be 0 (off) or at least 1, got 0.5"), std::string::npos) << flag.err;
  EXPECT_NE(run("info --help").out.find("[config: skeleton.max_edge_ratio; 0 (off) or at least 1]"), std::string::npos);
  const CmdResult plain = run("params");
  ASSERT_EQ(plain.code, 0) << plain.err;
  EXPECT_NE(plain.out.find("contours.slice_step = 0.4  (> 0; x local radius)"), std::string::npos) << plain.out;
}

TEST(Cli, GrowIsDeterministicAcrossThreadCounts) {
  const fs::path dir = test::temp_dir("cli_grow");
  ASSERT_EQ(run("--threads 1 grow --seed 9 -o " + (dir / "a.json").string()).code, 0);
  ASSERT_EQ(run("grow --seed 9 -o " + (dir / "b.json").string()).code, 0);
  ASSERT_EQ(run("grow --seed 10 -o " + (dir / "c.json").string()).code, 0);
  EXPECT_EQ(read_file(dir / "a.json"), read_file(dir / "b.json"));
  EXPECT_NE(read_file(dir / "a.json"), read_file(dir / "c.json"));
  const CmdResult info = run("info " + (dir / "a.json").string());
  EXPECT_EQ(info.code, 0) << info.err;
  EXPECT_NE(info.out.find("sanitize report"), std::string::npos);
  EXPECT_EQ(info.err, "");  // a grown tree needs no repairs
}

TEST(Cli, HugePagesChangeNoByte) {
  // The CLI re-executes itself with glibc's huge-page tunable (apps/common/huge_pages.h); opting out
  // with STRANDMESH_HUGE_PAGES=0 must give the same file, and so must a user's own tunable.
  const fs::path dir = test::temp_dir("cli_huge");
  const std::string tree = (dir / "tree.json").string();
  ASSERT_EQ(run("grow --seed 3 -o " + tree).code, 0);
  const std::string mesh = "mesh " + tree + " -q -o ";
  ASSERT_EQ(run(mesh + (dir / "on.glb").string()).code, 0);
  const CmdResult off = test::run_cli_env("STRANDMESH_HUGE_PAGES=0", mesh + (dir / "off.glb").string());
  ASSERT_EQ(off.code, 0) << off.err;
  const CmdResult user = test::run_cli_env("GLIBC_TUNABLES=glibc.malloc.hugetlb=0", mesh + (dir / "user.glb").string());
  ASSERT_EQ(user.code, 0) << user.err;
  const std::string on = read_file(dir / "on.glb");
  EXPECT_GT(on.size(), 1000u);
  EXPECT_EQ(on, read_file(dir / "off.glb"));
  EXPECT_EQ(on, read_file(dir / "user.glb"));
  // Where the kernel offers transparent huge pages, the default run uses them; opted out, not.
  std::string thp = read_file("/sys/kernel/mm/transparent_hugepage/enabled");
  const std::string note = "transparent huge pages";
  if (!thp.empty() && thp.find("[never]") == std::string::npos) {
    EXPECT_NE(run("-v info " + tree).err.find(note), std::string::npos);
  }
  EXPECT_EQ(test::run_cli_env("STRANDMESH_HUGE_PAGES=0", "-v info " + tree).err.find(note), std::string::npos);
}

TEST(Cli, MalformedInputExitsOneWithoutOutput) {
  const fs::path dir = test::temp_dir("cli_bad");
  const std::pair<const char*, const char*> cases[] = {
      {"truncated.json", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,)"},
      {"cycle.json", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":1},
                        {"id":1,"parent":2,"position":[0,0,1],"radius":1},{"id":2,"parent":1,"position":[0,0,2],"radius":1}]})"},
      {"negative.json", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":-1}]})"},
      {"empty.json", ""},
      {"garbage.swc", "\x7f\x45\x4c\x46\x02\x01\x01\n"},
  };
  for (const auto& [name, text] : cases) {
    SCOPED_TRACE(name);
    write_file_atomically(dir / name, text);
    const fs::path out = dir / (std::string(name) + ".out.json");
    const CmdResult r = run("info " + (dir / name).string() + " --export " + out.string());
    EXPECT_EQ(r.code, 1);
    EXPECT_EQ(r.err.rfind("error: ", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(name), std::string::npos) << r.err;  // names the file
    EXPECT_FALSE(fs::exists(out));
  }
  const CmdResult missing = run("info " + (dir / "does_not_exist.json").string());
  EXPECT_EQ(missing.code, 1);
  EXPECT_NE(missing.err.find("cannot open"), std::string::npos);
}

TEST(Cli, MeasuredTreeFormatsAreReadAndMalformedOnesNamed) {
  // The QSM and MTG files of tests/data/qsm through `info`, picked by extension (and by content
  // when the extension says nothing), then a malformed file of each new format: exit 1, the
  // place named, nothing written.
  const fs::path data = fs::path(STRANDMESH_SOURCE_DIR) / "tests/data/qsm";
  const fs::path dir = test::temp_dir("cli_formats");
  for (const char* f : {"rtwig_QSM.mat", "rtwig_QSM.csv", "rtwig_QSM2.csv", "openalea_mtg_boutdenoylum2.mtg"}) {
    SCOPED_TRACE(f);
    const CmdResult r = run("info -q --json " + (data / f).string());
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("\"nodes\""), std::string::npos);
  }
  fs::copy_file(data / "openalea_mtg_agraf.mtg", dir / "agraf_no_extension");
  const CmdResult agraf = run("info -q " + (dir / "agraf_no_extension").string() + " --units mm,0.1mm");
  EXPECT_EQ(agraf.code, 0) << agraf.err;
  EXPECT_NE(agraf.out.find("input 794"), std::string::npos) << agraf.out;
  const CmdResult mapped = run("info -q " + (data / "rtwig_QSM.csv").string() + " --columns radius=length");
  EXPECT_EQ(mapped.code, 0) << mapped.err;
  EXPECT_NE(run("info " + (data / "rtwig_QSM.csv").string() + " --units furlong").err.find("--units"), std::string::npos);

  const std::string csv = "ID,parentID,startX,startY,startZ,endX,endY,endZ,radius\n0,-1,0,0,0,0,0,1,0.1\n";
  const std::string mtg = "CODE:\tFORM-A\nMTG:\nENTITY-CODE\t\tXX\tYY\tZZ\tTopDia\n/P1\t\t0\t0\t0\t10\n";
  const std::tuple<const char*, std::string, const char*> cases[] = {
      {"nan.csv", csv + "1,0,0,0,1,0,0,2,abc\n", "nan.csv:3:17: column \"radius\": \"abc\" is not a number"},
      {"short.csv", csv + "1,0,0,0,1\n", "short.csv:3: 5 fields, the header (line 1) has 9"},
      {"nocol.csv", "ID,parentID,startX,startY,startZ\n", "nocol.csv:1: no column for the radius"},
      {"cyl_data.txt", "0.1\t1\t0\t0\t0\t0\t0\t1\t0\t2\n0.1\t1\t0\t0\t1\t0\t0\t1\t1\n",
       "cyl_data.txt:2: 9 fields, a TreeQSM cylinder line has at least 10"},
      {"text.mat", "not a MAT file at all", "text.mat: not a MATLAB MAT file"},
      {"bad.mtg", mtg + "^<1\t\t0\t0\t1\t10\n", "bad.mtg:5:2: expected a class symbol"},
      {"bad2.mtg", mtg + "^<P2\t\t0\tx\t1\t10\n", "bad2.mtg:5:9: feature YY: \"x\" is not a number"},
  };
  for (const auto& [name, text, message] : cases) {
    SCOPED_TRACE(name);
    write_file_atomically(dir / name, text);
    const fs::path out = dir / (std::string(name) + ".glb");
    const CmdResult r = run("mesh " + (dir / name).string() + " -o " + out.string());
    EXPECT_EQ(r.code, 1);
    EXPECT_NE(r.err.find(message), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out));
  }
}

TEST(Cli, InfoOnSamplesReportsRepairs) {
  const auto files = test::sample_skeletons();
  ASSERT_FALSE(files.empty()) << "tests/data/skeletons is empty";
  const fs::path dir = test::temp_dir("cli_samples");
  for (const auto& f : files) {
    SCOPED_TRACE(f.filename().string());
    const fs::path out = dir / f.filename();
    const CmdResult r = run("info --json " + f.string() + " --export " + out.string());
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.out.find("\"nodes\""), std::string::npos);
    EXPECT_TRUE(fs::exists(out));
    // The exported skeleton is already clean: re-importing it repairs nothing.
    const CmdResult again = run("info " + out.string());
    EXPECT_EQ(again.code, 0);
    EXPECT_EQ(again.err, "") << "re-import needed repairs";
  }
}

TEST(Cli, MeshWritesEveryFormatAndStats) {
  const fs::path dir = test::temp_dir("cli_mesh");
  ASSERT_EQ(run("grow --seed 1 -o " + (dir / "t.json").string()).code, 0);  // the default tree: checks pass
  for (const char* ext : {"glb", "gltf", "obj", "ply"}) {
    SCOPED_TRACE(ext);
    const fs::path out = dir / (std::string("t.") + ext);
    const CmdResult r = run("-q mesh " + (dir / "t.json").string() + " -o " + out.string() + " --stats " +
                            (dir / "stats.json").string());
    EXPECT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(fs::exists(out));
    EXPECT_GT(fs::file_size(out), 1000u);
  }
  const std::string stats = read_file(dir / "stats.json");
  for (const char* key : {"\"nodes\"", "\"strands\"", "\"particles\"", "\"slices\"", "\"vertices\"",
                          "\"triangles\"", "\"seconds\"", "\"skeleton\"", "\"contours\"", "\"meshing\"",
                          "\"export\"", "\"total\"", "\"fold_repair\"", "\"flips\""}) {
    EXPECT_NE(stats.find(key), std::string::npos) << key;
  }
  // The mesh passes its own check against the skeleton.
  const CmdResult check = run("check " + (dir / "t.glb").string() + " --skeleton " + (dir / "t.json").string());
  EXPECT_EQ(check.code, 0) << check.out;
  // Stage dumps, into a folder that does not exist yet and that also receives the mesh.
  const fs::path dump = dir / "dump";
  EXPECT_EQ(run("-q mesh " + (dir / "t.json").string() + " -o " + (dump / "t.ply").string() + " --dump-stages " +
                dump.string()).code,
            0);
  for (const char* f : {"skeleton.json", "particles.json", "strands.json", "contours.json", "stats.json", "t.ply"}) {
    EXPECT_TRUE(fs::exists(dump / f)) << f;
  }
}

TEST(Cli, LevelsOfDetailInOneGltfFileOrOneFileEach) {
  const fs::path dir = test::temp_dir("cli_lods");
  const std::string tree = (dir / "t.json").string();
  ASSERT_EQ(run("grow --seed 7 -o " + tree).code, 0);
  // glTF: one file, MSFT_lod on the scene's node; every level passes `check --lod K`.
  const CmdResult one = run("-q mesh " + tree + " -o " + (dir / "t.glb").string() + " --lods 3");
  ASSERT_EQ(one.code, 0) << one.err;
  EXPECT_FALSE(fs::exists(dir / "t_lod1.glb"));
  std::size_t previous = SIZE_MAX;
  for (int k = 0; k < 3; ++k) {
    const CmdResult c = run("check " + (dir / "t.glb").string() + " --lod " + std::to_string(k) + " --json");
    ASSERT_EQ(c.code, 0) << c.out << c.err;
    const auto report = nlohmann::json::parse(c.out);
    EXPECT_EQ(report["self_intersecting_pairs"], 0);
    EXPECT_LT(report["triangles"].get<std::size_t>(), previous);
    previous = report["triangles"].get<std::size_t>();
  }
  const CmdResult beyond = run("check " + (dir / "t.glb").string() + " --lod 3");
  EXPECT_EQ(beyond.code, 1);
  EXPECT_NE(beyond.err.find("level of detail 3 does not exist"), std::string::npos) << beyond.err;
  // One file, so standard output takes it too.
  const CmdResult piped = run("-q mesh " + tree + " -o - --lods 2");
  ASSERT_EQ(piped.code, 0) << piped.err;
  EXPECT_NE(piped.out.find("MSFT_lod"), std::string::npos);
  // --lod-files (and OBJ, PLY always): OUT_lodK.EXT beside OUT, not to standard output.
  ASSERT_EQ(run("-q mesh " + tree + " -o " + (dir / "f.glb").string() + " --lods 3 --lod-files").code, 0);
  ASSERT_EQ(run("-q mesh " + tree + " -o " + (dir / "f.ply").string() + " --lods 2").code, 0);
  for (const char* f : {"f.glb", "f_lod1.glb", "f_lod2.glb", "f.ply", "f_lod1.ply"}) EXPECT_TRUE(fs::exists(dir / f)) << f;
  EXPECT_EQ(read_file(dir / "f.glb").find("MSFT_lod"), std::string::npos);
  EXPECT_EQ(run("-q mesh " + tree + " -o - --output-format ply --lods 2").code, 2);
}

TEST(Cli, MeshNotesWherePairsWereLookedForNearJunctionsOnly) {
  // Over repair.count_pairs_up_to triangles the pairs are counted only where the fold repair
  // looked (near the junctions): the run says so with -v, and --stats records it. Within the limit it
  // says nothing of the kind. (The config spells the key as it was before the repair stage took
  // it, meshing.count_pairs_up_to: still read, with a warning naming the new key.)
  const fs::path dir = test::temp_dir("cli_count_pairs");
  ASSERT_EQ(run("grow --seed 1 -o " + (dir / "t.json").string()).code, 0);
  // (The fork retry, which counts them, is part of configs/separate.json.)
  { std::ofstream(dir / "small_limit.json") << R"({"meshing": {"count_pairs_up_to": 1000, "fork_retry": true}})"; }
  { std::ofstream(dir / "retry.json") << R"({"meshing": {"fork_retry": true}})"; }
  const std::string mesh =
      "mesh " + (dir / "t.json").string() + " -o " + (dir / "t.glb").string() + " --stats " + (dir / "s.json").string();
  const CmdResult limited = run(mesh + " -v --config " + (dir / "small_limit.json").string());
  ASSERT_EQ(limited.code, 0) << limited.err;
  EXPECT_NE(limited.err.find("meshing.count_pairs_up_to is now repair.count_pairs_up_to"), std::string::npos)
      << limited.err;
  const std::string note = "self-intersections were looked for near the junctions only";
  EXPECT_NE((limited.out + limited.err).find(note), std::string::npos) << limited.out << limited.err;
  EXPECT_FALSE(
      nlohmann::json::parse(read_file(dir / "s.json")).at("fork_retry").at("pairs_counted_everywhere").get<bool>());
  const CmdResult whole = run(mesh + " --config " + (dir / "retry.json").string());
  ASSERT_EQ(whole.code, 0) << whole.err;
  EXPECT_EQ((whole.out + whole.err).find(note), std::string::npos);
  EXPECT_TRUE(
      nlohmann::json::parse(read_file(dir / "s.json")).at("fork_retry").at("pairs_counted_everywhere").get<bool>());
}

TEST(Cli, BenchReportsThroughputAgainstThePaper) {
  // bench on a skeleton file: the figures on stdout and in --json agree, the paper's ratio
  // is particles per second over 564,632 / 2.75, and --check judges the mesh.
  const fs::path dir = test::temp_dir("cli_bench");
  ASSERT_EQ(run("grow --seed 1 -o " + (dir / "t.json").string()).code, 0);
  const CmdResult r =
      run("bench --skeleton " + (dir / "t.json").string() + " --repeat 2 --check --json " + (dir / "b.json").string());
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("particles/s"), std::string::npos);
  EXPECT_NE(r.out.find("x the paper's 205321 particles/s"), std::string::npos) << r.out;
  // (Genus 3: with the input kept, three pairs of the grown tree's branches cross and fuse.)
  EXPECT_NE(r.out.find("watertight, genus 3, 0 self-intersections"), std::string::npos) << r.out;
  const nlohmann::json j = nlohmann::json::parse(read_file(dir / "b.json"));
  const double rate = j.at("meshing_particles_per_second").get<double>();
  EXPECT_GT(rate, 0.0);
  const double times_paper = rate / (564632.0 / 2.75);
  EXPECT_NEAR(j.at("meshing_times_paper").get<double>(), times_paper, 1e-9 * times_paper);
  EXPECT_GT(j.at("triangles").get<double>(), 10000.0);
  EXPECT_TRUE(j.at("check").at("ok").get<bool>());
  EXPECT_EQ(run("bench --skeleton " + (dir / "missing.json").string()).code, 1);
}

TEST(Cli, CheckListsAsManyExamplesAsAsked) {
  // Three separate triangles: nine boundary edges.
  const fs::path dir = test::temp_dir("cli_check_examples");
  write_file_atomically(dir / "open.obj",
                        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv 3 0 0\nv 2 1 0\nv 4 0 0\nv 5 0 0\nv 4 1 0\n"
                        "f 1 2 3\nf 4 5 6\nf 7 8 9\n");
  auto listed = [&](const std::string& extra) {
    const CmdResult r = run("check --json " + (dir / "open.obj").string() + extra);
    EXPECT_EQ(r.code, 4) << r.err;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["boundary_edges"], 9);
    return j["examples"]["boundary_edges"].size();
  };
  EXPECT_EQ(listed(""), 5u);  // the default
  EXPECT_EQ(listed(" --examples 2"), 2u);
  EXPECT_EQ(listed(" --examples 100"), 9u);
}

TEST(Cli, MeshFailuresLeaveNoOutput) {
  const fs::path dir = test::temp_dir("cli_mesh_bad");
  write_file_atomically(dir / "bad.json", R"({"nodes":[{"id":0,"parent":-1,"position":[0,0,0],"radius":-1}]})");
  ASSERT_EQ(run("grow --seed 3 -o " + (dir / "ok.json").string()).code, 0);
  const CmdResult bad = run("mesh " + (dir / "bad.json").string() + " -o " + (dir / "bad.glb").string());
  EXPECT_EQ(bad.code, 1);
  EXPECT_NE(bad.err.find("negative"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "bad.glb"));
  // Unknown output format: a usage problem, reported before any work.
  const CmdResult ext = run("mesh " + (dir / "ok.json").string() + " -o " + (dir / "t.stl").string());
  EXPECT_EQ(ext.code, 1);
  EXPECT_FALSE(fs::exists(dir / "t.stl"));
  // A config with an unknown key.
  write_file_atomically(dir / "cfg.json", R"({"contours": {"slice_stepp": 1}})");
  const CmdResult cfg =
      run("mesh " + (dir / "ok.json").string() + " --config " + (dir / "cfg.json").string() + " -o " + (dir / "c.glb").string());
  EXPECT_EQ(cfg.code, 1);
  EXPECT_NE(cfg.err.find("unknown key \"slice_stepp\""), std::string::npos) << cfg.err;
  EXPECT_FALSE(fs::exists(dir / "c.glb"));
  // A value out of range (a zero slice step sliced forever).
  write_file_atomically(dir / "zero.json", R"({"contours": {"slice_step": 0, "min_slice_step": 0}})");
  const CmdResult zero = run("mesh " + (dir / "ok.json").string() + " --config " + (dir / "zero.json").string() +
                             " -o " + (dir / "z.glb").string());
  EXPECT_EQ(zero.code, 1);
  EXPECT_NE(zero.err.find("contours.slice_step must be > 0"), std::string::npos) << zero.err;
  EXPECT_FALSE(fs::exists(dir / "z.glb"));
  // An output folder that does not exist.
  EXPECT_EQ(run("mesh " + (dir / "ok.json").string() + " -o " + (dir / "nope" / "t.glb").string()).code, 1);
}

TEST(Cli, SuggestionsStdioExportOptionsAndGrownTreeWarnings) {
  const fs::path dir = test::temp_dir("cli_export");
  const std::string bin = std::string(STRANDMESH_BINARY_DIR) + "/strandmesh";
  // "Did you mean" for a mistyped command and option.
  const CmdResult cmd = run("mesj x.json -o y.glb");
  EXPECT_EQ(cmd.code, 2);
  EXPECT_NE(cmd.err.find("did you mean 'strandmesh mesh'"), std::string::npos) << cmd.err;
  const CmdResult opt = run("mesh x.json -o y.glb --pivott root");
  EXPECT_EQ(opt.code, 2);
  EXPECT_NE(opt.err.find("did you mean '--pivot'"), std::string::npos) << opt.err;
  const CmdResult attr = run("mesh x.json -o y.glb --attributes normal,brnch_id");
  EXPECT_EQ(attr.code, 1);
  EXPECT_NE(attr.err.find("did you mean \"branch_id\""), std::string::npos) << attr.err;
  // A grown tree through standard input and output, as y-up OBJ with the root at the origin.
  const CmdResult piped = run("grow --seed 2 -o - -q | " + bin + " mesh - -o - --output-format obj -q");
  ASSERT_EQ(piped.code, 0) << piped.err;
  EXPECT_EQ(piped.out.rfind("# strandmesh\n", 0), 0u);
  EXPECT_NE(piped.out.find("strandmesh-placement up y scale 1 translation 0 0 0\n"), std::string::npos);
  // Export options from the command line and from a config file's export section.
  ASSERT_EQ(run("grow --seed 2 -o " + (dir / "t.json").string()).code, 0);
  const CmdResult cm = run("mesh " + (dir / "t.json").string() + " -o " + (dir / "t.obj").string() + " --scale cm --up-axis z");
  ASSERT_EQ(cm.code, 0) << cm.err;
  EXPECT_NE(read_file(dir / "t.obj").find("strandmesh-placement up z scale 100 "), std::string::npos);
  write_file_atomically(dir / "c.json", R"({"export": {"pivot": "center", "compress": "meshopt"}})");
  const CmdResult cfg = run("mesh " + (dir / "t.json").string() + " --config " + (dir / "c.json").string() + " -o " +
                            (dir / "t.gltf").string());
  ASSERT_EQ(cfg.code, 0) << cfg.err;
  EXPECT_NE(read_file(dir / "t.gltf").find("EXT_meshopt_compression"), std::string::npos);
  // The grower's thin twig tips are by design: no warning, unless -v asks for everything.
  EXPECT_EQ(cfg.err.find("tip thinner than one particle spacing"), std::string::npos) << cfg.err;
  ASSERT_EQ(run("grow --preset conifer -o " + (dir / "conifer.json").string()).code, 0);  // has thin tips
  // (Its tips are thinner than a particle spacing with the shape edits of configs/separate.json.)
  const std::string clamp = " --config " + (fs::path(STRANDMESH_SOURCE_DIR) / "configs/separate.json").string();
  const CmdResult quiet = run("mesh " + (dir / "conifer.json").string() + clamp + " -o " + (dir / "v.glb").string());
  EXPECT_EQ(quiet.err.find("tip thinner than one particle spacing"), std::string::npos) << quiet.err;
  const CmdResult verbose =
      run("mesh " + (dir / "conifer.json").string() + clamp + " -o " + (dir / "v.glb").string() + " -v");
  EXPECT_NE(verbose.err.find("as grown on purpose: tip thinner"), std::string::npos) << verbose.err;
}

}  // namespace
}  // namespace sm
