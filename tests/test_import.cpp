// Readers of measured trees: cylinder models (TreeQSM .mat and text, SimpleForest / aRchi /
// rTwig CSV) and OpenAlea MTG, on fixtures built in code and on the files of tests/data/qsm.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <matio.h>

#include "core/errors.h"
#include "core/file_io.h"
#include "skeleton/build.h"
#include "skeleton/import/cylinders.h"
#include "skeleton/import/formats.h"
#include "skeleton/io.h"
#include "tests/fixtures.h"
#ifdef STRANDMESH_IMPORT_SLOW_TESTS
#include "meshcheck/checks.h"
#include "pipeline/pipeline.h"
#endif

namespace sm {
namespace {

namespace fs = std::filesystem;

const fs::path kData = fs::path(STRANDMESH_SOURCE_DIR) / "tests/data/qsm";

/// The message of the InvalidInputError `f` throws ("" when it throws none).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const InvalidInputError& e) {
    return e.what();
  }
  return "";
}

std::size_t index_of(const RawSkeleton& raw, dvec3 p) {
  for (std::size_t i = 0; i < raw.size(); ++i)
    if (glm::length(raw.position[i] - p) < 1e-9) return i;
  return raw.size();
}

/// The node that is node i's parent (raw.size() for the root).
std::size_t parent_of(const RawSkeleton& raw, std::size_t i) {
  for (std::size_t k = 0; k < raw.size(); ++k)
    if (raw.id[k] == raw.parent_id[i]) return k;
  return raw.size();
}

// --- cylinders -> nodes ------------------------------------------------------------------

/// A trunk of two cylinders (the second continuing the first) and a branch.
CylinderTable trunk_and_branch(dvec3 branch_start) {
  CylinderTable t;
  t.source = "test";
  auto add = [&](std::int64_t id, std::int64_t parent, dvec3 s, dvec3 e, double r) {
    t.id.push_back(id);
    t.parent.push_back(parent);
    t.start.push_back(s);
    t.end.push_back(e);
    t.radius.push_back(r);
    t.where.push_back("cylinder " + std::to_string(id));
  };
  add(1, 0, {0, 0, 0}, {0, 0, 2}, 0.2);
  add(2, 1, {0, 0, 2}, {0, 0, 3}, 0.15);
  add(3, 1, branch_start, {1, 0, 1.5}, 0.05);
  return t;
}

TEST(Cylinders, ChainSharesEndsAndSideBranchSplitsItsParent) {
  // The branch starts on the trunk's surface halfway up: the trunk gets a node on its axis
  // there (its own radius), the branch's start a node of the branch's radius on top of it.
  const RawSkeleton raw = cylinders_to_skeleton(trunk_and_branch({0.2, 0, 1}));
  ASSERT_EQ(raw.size(), 6u);  // root, axis node, trunk end, branch start, branch end, top
  const std::size_t root = index_of(raw, {0, 0, 0}), axis = index_of(raw, {0, 0, 1}), top1 = index_of(raw, {0, 0, 2}),
                    top2 = index_of(raw, {0, 0, 3}), bstart = index_of(raw, {0.2, 0, 1}),
                    bend = index_of(raw, {1, 0, 1.5});
  ASSERT_LT(std::max({root, axis, top1, top2, bstart, bend}), raw.size());
  EXPECT_EQ(raw.parent_id[root], -1);
  EXPECT_EQ(parent_of(raw, axis), root);
  EXPECT_EQ(parent_of(raw, top1), axis);
  EXPECT_EQ(parent_of(raw, top2), top1);  // the continuation shares the trunk's end
  EXPECT_EQ(parent_of(raw, bstart), axis);
  EXPECT_EQ(parent_of(raw, bend), bstart);
  EXPECT_DOUBLE_EQ(raw.radius[axis], 0.2);
  EXPECT_DOUBLE_EQ(raw.radius[bstart], 0.05);
  EXPECT_DOUBLE_EQ(raw.radius[top2], 0.15);
  EXPECT_NE(raw.where[bstart].find("cylinder 3"), std::string::npos);
  EXPECT_NO_THROW(build_skeleton(raw));
}

TEST(Cylinders, BranchOnTheAxisOrAtAnEndNeedsNoExtraNode) {
  // On the axis: the axis node is the branch's start.
  RawSkeleton raw = cylinders_to_skeleton(trunk_and_branch({0, 0, 1}));
  EXPECT_EQ(raw.size(), 5u);
  EXPECT_EQ(parent_of(raw, index_of(raw, {1, 0, 1.5})), index_of(raw, {0, 0, 1}));
  // At the trunk's end: a second child of the end node, no split.
  raw = cylinders_to_skeleton(trunk_and_branch({0, 0, 2}));
  EXPECT_EQ(raw.size(), 4u);
  EXPECT_EQ(parent_of(raw, index_of(raw, {1, 0, 1.5})), index_of(raw, {0, 0, 2}));
}

TEST(Cylinders, ExtensionsCloseTheirGaps) {
  // TreeQSM's continuation may start a little off its parent's end: with the extension
  // column it still starts there; without it, it is a branch starting near the end.
  CylinderTable t = trunk_and_branch({0.2, 0, 1});
  t.start[1] = {0.05, 0, 2.02};
  t.extension = {2, 0, 0};
  RawSkeleton raw = cylinders_to_skeleton(t);
  EXPECT_EQ(raw.size(), 6u);
  EXPECT_EQ(parent_of(raw, index_of(raw, {0, 0, 3})), index_of(raw, {0, 0, 2}));
  t.extension.clear();
  raw = cylinders_to_skeleton(t);
  EXPECT_EQ(raw.size(), 7u);
  EXPECT_EQ(parent_of(raw, index_of(raw, {0.05, 0, 2.02})), index_of(raw, {0, 0, 2}));
}

TEST(Cylinders, TwoBranchesAtOneHeightShareTheAxisNode) {
  CylinderTable t = trunk_and_branch({0.2, 0, 1});
  t.id.push_back(4);
  t.parent.push_back(1);
  t.start.push_back({-0.2, 0, 1});
  t.end.push_back({-1, 0, 1.5});
  t.radius.push_back(0.05);
  t.where.push_back("cylinder 4");
  const RawSkeleton raw = cylinders_to_skeleton(t);
  EXPECT_EQ(raw.size(), 8u);
  EXPECT_EQ(parent_of(raw, index_of(raw, {-0.2, 0, 1})), index_of(raw, {0, 0, 1}));
}

TEST(Cylinders, BadTopologyNamesTheCylinder) {
  CylinderTable t = trunk_and_branch({0.2, 0, 1});
  t.id[2] = 2;
  EXPECT_NE(error_of([&] { cylinders_to_skeleton(t); }).find("cylinder 3: cylinder id 2 is also the id at cylinder 2"),
            std::string::npos);
  t = trunk_and_branch({0.2, 0, 1});
  t.parent[2] = 9;
  EXPECT_NE(error_of([&] { cylinders_to_skeleton(t); }).find("cylinder 3: parent id 9 is no cylinder's id"),
            std::string::npos);
  t = trunk_and_branch({0.2, 0, 1});
  t.parent[0] = 2;  // 1 -> 2 -> 1
  EXPECT_NE(error_of([&] { cylinders_to_skeleton(t); }).find("cylinder 1: the cylinder's parents form a cycle"),
            std::string::npos);
  t.parent[0] = 1;
  EXPECT_NE(error_of([&] { cylinders_to_skeleton(t); }).find("is its own parent"), std::string::npos);
}

// --- cylinder tables ---------------------------------------------------------------------

const char* kSimpleForest =
    " ID, parentID, startX, startY, startZ, endX, endY, endZ, radius, length\n"
    "0,-1,10,20,250,10,20,251,0.1,1\n"
    "1,0,10,20,251,10,20,252,0.08,1\n"
    "2,0,10,20,251,10.5,20,251.5,0.03,0.7\n";

TEST(Tables, SimpleForestColumnsByName) {
  const RawSkeleton raw = parse_cylinder_table(kSimpleForest, "sf.csv");
  ASSERT_EQ(raw.size(), 4u);  // children start at the parent's end: one shared node
  EXPECT_EQ(index_of(raw, {10, 20, 250}), 0u);  // georeferenced coordinates kept
  const std::size_t fork = index_of(raw, {10, 20, 251});
  EXPECT_EQ(parent_of(raw, index_of(raw, {10, 20, 252})), fork);
  EXPECT_EQ(parent_of(raw, index_of(raw, {10.5, 20, 251.5})), fork);
  EXPECT_NE(raw.where[fork].find("line 2 (cylinder id 0)"), std::string::npos);
}

TEST(Tables, ArchiTreeQsmStylesAndMappedColumns) {
  // aRchi: 1-based ids, root parent 0, radius_cyl, an extension column.
  const RawSkeleton archi = parse_cylinder_table(
      "startX,startY,startZ,endX,endY,endZ,cyl_ID,parent_ID,extension_ID,radius_cyl\n"
      "0,0,0,0,0,1,1,0,2,0.1\n"
      "0,0,1,0,0,2,2,1,0,0.08\n",
      "archi.csv");
  EXPECT_EQ(archi.size(), 3u);
  // R export of a TreeQSM table: quoted names, a row-name column, start/axis/length, diameter.
  const RawSkeleton r = parse_cylinder_table(
      "\"\",\"id\",\"parent\",\"start.x\",\"start.y\",\"start.z\",\"axis.x\",\"axis.y\",\"axis.z\",\"length\",\"diameter\"\n"
      "\"1\",1,NA,0,0,0,0,0,1,2,0.2\n"
      "\"2\",2,1,0,0,2,0,0,2,1,0.1\n",
      "r.csv");
  ASSERT_EQ(r.size(), 3u);
  EXPECT_LT(index_of(r, {0, 0, 3}), 3u);  // an axis that is not unit length still spans `length`
  EXPECT_DOUBLE_EQ(r.radius[index_of(r, {0, 0, 2})], 0.1);
  // Semicolons, other names, mapped with --columns.
  const RawSkeleton m = parse_cylinder_table("k;p;a;b;c;d;e;f;rr\n5;-1;0;0;0;0;0;1;0.1\n6;5;0;0;1;1;0;2;0.05\n", "m.csv",
                                             {{"id", "k"}, {"parent", "p"}, {"start_x", "a"}, {"start_y", "b"},
                                              {"start_z", "c"}, {"end_x", "d"}, {"end_y", "e"}, {"end_z", "f"},
                                              {"radius", "rr"}});
  EXPECT_EQ(m.size(), 3u);
  EXPECT_LT(index_of(m, {1, 0, 2}), 3u);
}

TEST(Tables, TreeQsmTextExport) {
  // cyl_data: radius length start(3) axis(3) parent extension branch order position added rad0
  const RawSkeleton raw = parse_cylinder_table(
      "0.1\t1\t0\t0\t0\t0\t0\t1\t0\t2\t1\t0\t1\t0\t0.1\n"
      "0.08\t1\t0\t0\t1\t0\t0\t1\t1\t0\t1\t0\t2\t0\t0.08\n"
      "0.03\t0.5\t0.1\t0\t0.5\t1\t0\t0\t1\t0\t2\t1\t1\t0\t0.03\n",
      "cyl_data_tree.txt");
  ASSERT_EQ(raw.size(), 6u);  // the branch starts on the trunk's surface halfway up
  EXPECT_EQ(parent_of(raw, index_of(raw, {0.1, 0, 0.5})), index_of(raw, {0, 0, 0.5}));
  EXPECT_LT(index_of(raw, {0.6, 0, 0.5}), raw.size());
}

TEST(Tables, MalformedTablesNameLineAndColumn) {
  struct Case {
    std::string text, message;
  };
  const std::vector<Case> cases{
      {"ID,parentID,startX,startY,startZ,endX,endY,endZ,radius\n0,-1,0,0,0,0,0,1,0.1\n1,0,0,0,1,0,0,2,O.1\n",
       "t.csv:3:17: column \"radius\": \"O.1\" is not a number"},
      {"ID,parentID,startX,startY,startZ,endX,endY,endZ,radius\n0,-1,0,0,0,0,0,1,0.1\n1,0,0,0,1,0,0,2\n",
       "t.csv:3: 8 fields, the header (line 1) has 9"},
      {"ID,parentID,startX,startY,startZ,endX,endY,endZ\n0,-1,0,0,0,0,0,1\n",
       "t.csv:1: no column for the radius (radius; looked for radius, radiuscyl"},
      {"ID,parentID,startX,startY,startZ,endX,endY,endZ,radius\n0,-1,0,0,0,0,0,1,0.1\n1,7,0,0,1,0,0,2,0.1\n",
       "t.csv: line 3 (cylinder id 1): parent id 7 is no cylinder's id"},
      {"ID,parentID,startX,startY,startZ,endX,endY,endZ,radius\n0,-1,0,0,0,0,0,1,0.1\n1,0.5,0,0,1,0,0,2,0.1\n",
       "t.csv:3:3: column \"parentID\": \"0.5\" is not an integer"},
      {"0.1 1 0 0 0 0 0 1 0\n", "t.csv:1: 9 fields, a TreeQSM cylinder line has at least 10"},
      {"0.1 1 0 0 0 0 0 1 0 0\n0.1 1 0 0 x 0 0 1 1 0\n", "t.csv:2:11: start z: \"x\" is not a number"},
      {"ID,parentID,startX,startY,startZ,endX,endY,endZ,radius\n", "t.csv:1: a header but no cylinders"},
  };
  for (const Case& c : cases) {
    const std::string e = error_of([&] { parse_cylinder_table(c.text, "t.csv"); });
    EXPECT_NE(e.find(c.message), std::string::npos) << "got: " << e << "\nwanted: " << c.message;
  }
  EXPECT_NE(error_of([&] { parse_cylinder_table(kSimpleForest, "t.csv", {{"radius", "rad"}}); })
                .find("t.csv:1: --columns radius=rad: the header has no column \"rad\""),
            std::string::npos);
  EXPECT_NE(error_of([&] { parse_cylinder_table(kSimpleForest, "t.csv", {{"girth", "radius"}}); })
                .find("unknown field \"girth\""),
            std::string::npos);
}

// --- TreeQSM .mat ------------------------------------------------------------------------

/// Writes a MAT v5 file with struct `var`.cylinder holding the given double arrays.
void write_mat(const fs::path& path, const char* var,
               const std::vector<std::pair<const char*, std::pair<std::vector<double>, std::size_t>>>& fields) {
  mat_t* mat = Mat_CreateVer(path.c_str(), nullptr, MAT_FT_MAT5);
  ASSERT_NE(mat, nullptr);
  std::vector<const char*> names;
  for (const auto& f : fields) names.push_back(f.first);
  std::size_t one[2] = {1, 1};
  matvar_t* cyl = Mat_VarCreateStruct("cylinder", 2, one, names.data(), unsigned(names.size()));
  for (const auto& [name, data] : fields) {
    std::size_t dims[2] = {data.first.size() / data.second, data.second};
    matvar_t* v = Mat_VarCreate(name, MAT_C_DOUBLE, MAT_T_DOUBLE, 2, dims, const_cast<double*>(data.first.data()), 0);
    Mat_VarSetStructFieldByName(cyl, name, 0, v);
  }
  const char* top[] = {"cylinder"};
  matvar_t* qsm = Mat_VarCreateStruct(var, 2, one, top, 1);
  Mat_VarSetStructFieldByName(qsm, "cylinder", 0, cyl);
  Mat_VarWrite(mat, qsm, MAT_COMPRESSION_NONE);
  Mat_VarFree(qsm);
  Mat_Close(mat);
}

TEST(TreeQsmMat, ReadsTheQsmStruct) {
  const fs::path dir = test::temp_dir("import_mat");
  // Two cylinders (column-major n x 3 arrays), the second continuing the first.
  write_mat(dir / "qsm.mat", "QSM",
            {{"radius", {{0.1, 0.08}, 1}},
             {"length", {{1, 1}, 1}},
             {"start", {{5, 5, 6, 6, 250, 251}, 3}},
             {"axis", {{0, 0, 0, 0, 1, 1}, 3}},
             {"parent", {{0, 1}, 1}},
             {"extension", {{2, 0}, 1}}});
  const RawSkeleton raw = read_skeleton(dir / "qsm.mat");
  ASSERT_EQ(raw.size(), 3u);
  EXPECT_LT(index_of(raw, {5, 6, 252}), 3u);
  EXPECT_NE(raw.where[0].find("cylinder 1"), std::string::npos);
}

TEST(TreeQsmMat, MalformedFilesNameTheVariable) {
  const fs::path dir = test::temp_dir("import_mat_bad");
  write_mat(dir / "cols.mat", "QSM",
            {{"radius", {{0.1, 0.08, 0.1, 0.08}, 2}},
             {"length", {{1, 1}, 1}},
             {"start", {{5, 5, 6, 6, 250, 251}, 3}},
             {"axis", {{0, 0, 0, 0, 1, 1}, 3}},
             {"parent", {{0, 1}, 1}}});
  EXPECT_NE(error_of([&] { read_skeleton(dir / "cols.mat"); }).find("QSM.cylinder.radius must have 1 column, it has 2"),
            std::string::npos);
  write_mat(dir / "parent.mat", "OptQSM",
            {{"radius", {{0.1, 0.08}, 1}},
             {"length", {{1, 1}, 1}},
             {"start", {{5, 5, 6, 6, 250, 251}, 3}},
             {"axis", {{0, 0, 0, 0, 1, 1}, 3}},
             {"parent", {{0, 7}, 1}}});
  EXPECT_NE(error_of([&] { read_skeleton(dir / "parent.mat"); })
                .find("OptQSM.cylinder.parent(2) = 7 is not a cylinder number (1 to 2, or 0 for the root)"),
            std::string::npos);
  write_mat(dir / "missing.mat", "QSM", {{"radius", {{0.1}, 1}}});
  EXPECT_NE(error_of([&] { read_skeleton(dir / "missing.mat"); }).find("QSM.cylinder.length is missing"),
            std::string::npos);
  // A mutated rtwig_QSM.mat (fuzz/fuzz_skeleton_mat.cpp) whose struct libmatio returned without
  // data (it crashed libmatio's field lookup), and a 371-byte file declaring millions of struct
  // elements (4 GB and minutes inside libmatio): both refused before libmatio reads them.
  EXPECT_NE(error_of([&] { read_skeleton(kData / "fuzz_struct_without_data.mat"); })
                .find("fuzz_struct_without_data.mat: not a valid MAT file at byte 128"),
            std::string::npos);
  EXPECT_NE(error_of([&] { read_skeleton(kData / "fuzz_huge_struct.mat"); }).find("not a valid MAT file at byte"),
            std::string::npos);
  // A struct claiming more fields than its bytes hold, built by hand: the walk names it.
  write_mat(dir / "ok.mat", "QSM",
            {{"radius", {{0.1, 0.08}, 1}},
             {"length", {{1, 1}, 1}},
             {"start", {{5, 5, 6, 6, 250, 251}, 3}},
             {"axis", {{0, 0, 0, 0, 1, 1}, 3}},
             {"parent", {{0, 1}, 1}}});
  std::string bytes = read_file(dir / "ok.mat");
  const std::size_t dims = bytes.find(std::string("\x05\0\0\0\x08\0\0\0\x01\0\0\0\x01\0\0\0", 16), 128);
  ASSERT_NE(dims, std::string::npos);  // the QSM struct's dimensions 1 x 1
  bytes[dims + 8] = '\x7f';           // 127 x 1 elements
  write_file_atomically(dir / "huge.mat", bytes);
  EXPECT_NE(error_of([&] { read_skeleton(dir / "huge.mat"); }).find("127 elements x 1 fields in"), std::string::npos);
  write_file_atomically(dir / "text.mat", "radius,length\n");
  EXPECT_NE(error_of([&] { read_skeleton(dir / "text.mat"); }).find("text.mat: not a MATLAB MAT file"), std::string::npos);
}

// --- MTG ---------------------------------------------------------------------------------

std::string mtg(const std::string& code) {
  return "CODE:\tFORM-A\n\nCLASSES:\nSYMBOL\tSCALE\tDECOMPOSITION\tINDEXATION\tDEFINITION\n"
         "$\t0\tFREE\tFREE\tIMPLICIT\nP\t1\tFREE\tFREE\tEXPLICIT\nA\t2\tFREE\tFREE\tEXPLICIT\n"
         "S\t3\tFREE\tFREE\tEXPLICIT\n\nDESCRIPTION:\nLEFT\tRIGHT\tRELTYPE\tMAX\n\nFEATURES:\nNAME\tTYPE\n"
         "XX\tREAL\nYY\tREAL\nZZ\tREAL\nTopDia\tREAL\n\nMTG:\n"
         "ENTITY-CODE\t\t\t\tXX\tYY\tZZ\tTopDia\n" +
         code;
}

TEST(Mtg, TopologyColumnsRangesAndDiameters) {
  // A trunk axis A1 of S1..S4 (S2, S3 written as a range without features), a branch A1 on
  // S4 whose first segment is at the branch's own point, and a diameter left out (inherited).
  const std::string text = mtg(
      "/P1\n"
      "^/A1\t\t\t\t0\t0\t0\t20\n"
      "^/S1\t\t\t\t0\t0\t10\t18\n"
      "^<<S3\n"
      "^<S4\t\t\t\t0\t0\t30\t\n"
      "\t+A1\t\t\t5\t0\t35\t6\n"
      "\t^/S1\t\t\t5\t0\t35\t6\n"
      "\t^<S2\t\t\t10\t0\t40\t4\n");
  const RawSkeleton raw = parse_mtg(text, "t.mtg");
  ASSERT_EQ(raw.size(), 5u);  // A1 base, S1, S4, branch (A1 = its S1), S2
  EXPECT_EQ(raw.parent_id[0], -1);
  EXPECT_EQ(parent_of(raw, index_of(raw, {0, 0, 10})), index_of(raw, {0, 0, 0}));
  EXPECT_EQ(parent_of(raw, index_of(raw, {0, 0, 30})), index_of(raw, {0, 0, 10}));  // through S2, S3
  EXPECT_EQ(parent_of(raw, index_of(raw, {5, 0, 35})), index_of(raw, {0, 0, 30}));
  EXPECT_EQ(parent_of(raw, index_of(raw, {10, 0, 40})), index_of(raw, {5, 0, 35}));
  EXPECT_DOUBLE_EQ(raw.radius[index_of(raw, {0, 0, 30})], 9.0);  // S1's 18 inherited, halved
  EXPECT_DOUBLE_EQ(raw.radius[index_of(raw, {10, 0, 40})], 2.0);
  EXPECT_NE(raw.where[index_of(raw, {0, 0, 30})].find("line 26 (S4)"), std::string::npos);
  // Through read_skeleton: cm and mm by default, or as --units says.
  const fs::path dir = test::temp_dir("import_mtg");
  write_file_atomically(dir / "t.mtg", text);
  RawSkeleton m = read_skeleton(dir / "t.mtg");
  EXPECT_LT(index_of(m, {0, 0, 0.3}), m.size());
  EXPECT_DOUBLE_EQ(m.radius[index_of(m, {0, 0, 0.3})], 0.009);
  ReadOptions o;
  std::tie(o.length_unit, o.thickness_unit) = parse_units("mm,0.1mm");
  m = read_skeleton(dir / "t.mtg", o);
  EXPECT_LT(index_of(m, {0, 0, 0.03}), m.size());
  EXPECT_NEAR(m.radius[index_of(m, {0, 0, 0.03})], 0.0009, 1e-15);
}

TEST(Mtg, MalformedFilesNameLineAndColumn) {
  struct Case {
    std::string text, message;
  };
  const std::vector<Case> cases{
      {mtg("/P1\n^/A1\t\t\t\t0\t0\t0\t20\n^/Q1\t\t\t\t0\t0\t1\t20\n"), "t.mtg:24:3: unknown class \"Q\""},
      {mtg("/P1\n\t^/A1\t\t\t0\t0\t0\t20\n"), "t.mtg:23:2: '^' refers to the last entity of an earlier line"},
      {mtg("/P1\n\t\t/A1\t\t0\t0\t0\t20\n"), "t.mtg:23:3: the line is indented with no line one column to its left"},
      {mtg("/P1\n^/A1\t\t\t\t0\t0,5\t0\t20\n"), "t.mtg:23:11: feature YY: \"0,5\" is not a number"},
      {mtg("/P1\n^/A1\t\t\t\t0\t\t0\t20\n"), "t.mtg:23: the entity has only 2 of its 3 coordinates"},
      {mtg("/P1\n^/A1\t\t\t\t0\t0\t0\t20\n^<<S3\n"), "t.mtg:24:2: a range \"<<S3\" must follow an entity of the same class"},
      {mtg("/P1\n^/A1\t\t\t\t0\t0\t0\t20\n^A2\n"), "t.mtg:24:2: expected '/', '<', '+' or \"<<\" before an entity"},
      {mtg("/P1\n"), "t.mtg: no entity has coordinates"},
      {"CODE:\tFORM-A\nCLASSES:\n", "t.mtg: no MTG: section"},
      {"MTG:\nENTITY-CODE\t\tA\tB\n/P1\n", "t.mtg:2: no coordinate features"},
  };
  for (const Case& c : cases) {
    const std::string e = error_of([&] { parse_mtg(c.text, "t.mtg"); });
    EXPECT_NE(e.find(c.message), std::string::npos) << "got: " << e << "\nwanted: " << c.message;
  }
}

// --- detection and options ---------------------------------------------------------------

TEST(Import, FormatByExtensionThenContent) {
  EXPECT_EQ(detect_skeleton_format("a.json", ""), SkeletonFormat::json);
  EXPECT_EQ(detect_skeleton_format("a.MTG", ""), SkeletonFormat::mtg);
  EXPECT_EQ(detect_skeleton_format("a.mat", ""), SkeletonFormat::mat);
  EXPECT_EQ(detect_skeleton_format("a.csv", "ID,parentID\n"), SkeletonFormat::table);
  EXPECT_EQ(detect_skeleton_format("a.txt", "# swc\n1 1 0 0 0 1 -1\n"), SkeletonFormat::swc);
  EXPECT_EQ(detect_skeleton_format("cyl_data.txt", "0.1\t1\t0\t0\t0\t0\t0\t1\t0\t2\n"), SkeletonFormat::table);
  EXPECT_EQ(detect_skeleton_format("tree", "  {\"nodes\": []}"), SkeletonFormat::json);
  EXPECT_EQ(detect_skeleton_format("tree", "MATLAB 5.0 MAT-file"), SkeletonFormat::mat);
  EXPECT_EQ(detect_skeleton_format("tree", "CODE:\tFORM-A\nMTG:\n"), SkeletonFormat::mtg);
  EXPECT_EQ(detect_skeleton_format("tree", "ID,parentID,startX\n"), SkeletonFormat::table);
}

TEST(Import, UnitsAndColumnOptions) {
  EXPECT_EQ(parse_units("cm"), std::make_pair(0.01, 0.01));
  const auto [l, t] = parse_units("mm,0.1mm");
  EXPECT_DOUBLE_EQ(l, 0.001);
  EXPECT_DOUBLE_EQ(t, 0.0001);
  EXPECT_DOUBLE_EQ(parse_units("0.3048").first, 0.3048);
  EXPECT_DOUBLE_EQ(parse_units("ft").first, 0.3048);
  EXPECT_THROW(parse_units("furlong"), UsageError);
  EXPECT_THROW(parse_units("-1mm"), UsageError);
  EXPECT_THROW(parse_units("cm,"), UsageError);
  const ColumnMap m = parse_column_map("radius=r_m, parent=par");
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[1], std::make_pair(std::string("parent"), std::string("par")));
  EXPECT_THROW(parse_column_map("radius"), UsageError);
}

// --- the measured trees of tests/data/qsm ------------------------------------------------

struct Box {
  dvec3 lo{1e300}, hi{-1e300};
};
Box box_of(const RawSkeleton& raw) {
  Box b;
  for (const dvec3& p : raw.position) {
    b.lo = glm::min(b.lo, p);
    b.hi = glm::max(b.hi, p);
  }
  return b;
}

TEST(MeasuredTrees, ThreeQsmProgramsAgreeOnTheTree) {
  // One laser-scanned tree modelled by TreeQSM (.mat), SimpleForest and aRchi (rTwig's
  // examples): the bounding boxes of their nodes agree within 10 cm, georeferenced (z ~254 m).
  const RawSkeleton mat = read_skeleton(kData / "rtwig_QSM.mat");
  const RawSkeleton sf = read_skeleton(kData / "rtwig_QSM.csv");
  const RawSkeleton archi = read_skeleton(kData / "rtwig_QSM2.csv");
  EXPECT_GE(mat.size(), 1137u);  // 1136 cylinders: an end each, the root's start, side starts
  EXPECT_EQ(sf.size(), 1150u);   // 1149 cylinders, every child at its parent's end
  EXPECT_EQ(archi.size(), 1232u);
  const Box a = box_of(mat), b = box_of(sf), c = box_of(archi);
  for (int k = 0; k < 3; ++k) {
    for (const Box* x : {&b, &c}) {
      EXPECT_NEAR(a.lo[k], x->lo[k], 0.10) << "axis " << k;
      EXPECT_NEAR(a.hi[k], x->hi[k], 0.10) << "axis " << k;
    }
    EXPECT_NEAR(b.lo[k], c.lo[k], 0.10);
    EXPECT_NEAR(b.hi[k], c.hi[k], 0.10);
  }
  EXPECT_NEAR(a.lo.z, 253.9, 0.1);
  for (const RawSkeleton* raw : {&mat, &sf, &archi}) EXPECT_NO_THROW(build_skeleton(*raw));
}

TEST(MeasuredTrees, MtgFilesGiveTheConvertedTrees) {
  // The walnut is in cm with diameters in mm, the apple tree in mm with 0.1 mm.
  for (const auto& [name, units] : {std::pair{"boutdenoylum2", "cm,mm"}, std::pair{"agraf", "mm,0.1mm"}}) {
    ReadOptions o;
    std::tie(o.length_unit, o.thickness_unit) = parse_units(units);
    const RawSkeleton got = read_skeleton(kData / ("openalea_mtg_" + std::string(name) + ".mtg"), o);
    const RawSkeleton want = read_skeleton(kData / ("mtg_" + std::string(name) + ".json"));
    ASSERT_EQ(got.size(), want.size()) << name;
    for (std::size_t i = 0; i < got.size(); ++i) {
      ASSERT_EQ(got.parent_id[i], want.parent_id[i]) << name << " node " << i;
      ASSERT_NEAR(glm::length(got.position[i] - want.position[i]), 0.0, 1e-9) << name << " node " << i;
      ASSERT_NEAR(got.radius[i], want.radius[i], 1e-9) << name << " node " << i;
    }
  }
}

#ifdef STRANDMESH_IMPORT_SLOW_TESTS
TEST(MeasuredTreesSlow, EachMeshesClosed) {
  // Every measured tree through the whole pipeline with the defaults: one closed, oriented
  // 2-manifold holding every thick node, with no handle its crossing branches do not imply
  // (the defaults fuse crossings in place since 0.2: agraf has 4). Self-intersections and
  // fidelity are printed, not asserted (the aRchi model keeps 13 pairs on 2026-11-27;
  // docs/formats.md).
  // (The thick nodes left outside are a regression bound where issue 30 is not met: agraf 1
  // of 457, measured against the sanitized skeleton, on 2026-11-29.)
  const std::tuple<const char*, const char*, std::size_t> files[] = {{"rtwig_QSM.mat", "", 0},
                                                                     {"rtwig_QSM.csv", "", 0},
                                                                     {"rtwig_QSM2.csv", "", 0},
                                                                     {"openalea_mtg_boutdenoylum2.mtg", "cm,mm", 0},
                                                                     {"openalea_mtg_agraf.mtg", "mm,0.1mm", 1}};
  for (const auto& [file, units, thick_outside] : files) {
    SCOPED_TRACE(file);
    ReadOptions o;
    if (*units) std::tie(o.length_unit, o.thickness_unit) = parse_units(units);
    const PipelineResult r = run_pipeline(read_skeleton(kData / file, o), {});
    MeshCheckParams cp;
    cp.skeleton = &r.skeleton.skeleton;
    cp.implied_genus = true;
    const MeshCheckReport c = check_mesh(r.mesh.mesh, cp);
    EXPECT_TRUE(c.closed && c.edge_manifold && c.vertex_manifold && c.oriented);
    EXPECT_EQ(c.components, 1u);
    ASSERT_TRUE(c.genus && c.implied_genus_checked);
    EXPECT_GE(*c.genus, 0);
    EXPECT_LE(*c.genus, c.implied_genus);
    EXPECT_GE(c.thick_nodes_inside + thick_outside, c.thick_nodes);
    std::printf("%-32s %7zu triangles, %3zu self-intersecting pairs, fidelity p95 %.3f\n", file,
                r.mesh.mesh.triangle_count(), c.self_intersecting_pairs, c.fidelity_p95);
  }
}
#endif

}  // namespace
}  // namespace sm
