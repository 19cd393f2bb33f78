#pragma once
/// Many trees in one run (`strandmesh batch`): the list of trees, sharding, resumption by
/// hashes, and the per-tree records and summaries. apps/cli/cmd_batch.cpp runs the trees;
/// this library holds what does not mesh (docs/batch.md is the user's description).
///
/// Output folder: for each tree NAME, NAME.glb (or the chosen mesh format), NAME.png (a
/// thumbnail) and NAME.stats.json (its record: status, hashes, figures, checks); then
/// summary.csv and index.html over all trees, or, for shard I of N, shards/I-of-N.csv, which
/// merge_shards() turns into the same summary.csv and index.html. Every file depends only on
/// the inputs and the configuration, never on timing, thread counts or sharding, so the
/// same batch gives the same bytes however it is run.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "skeleton/io.h"

namespace sm::batch {

/// One tree of a batch.
struct TreeJob {
  std::size_t index = 0;        ///< position in the whole batch (before sharding)
  std::string name;             ///< output base name, unique in the batch ("oak_017")
  std::filesystem::path input;  ///< skeleton file, as given (or relative to its manifest)
  ReadOptions read;             ///< how to read it (the batch's options, or the manifest entry's)
  nlohmann::json config;        ///< per-tree parameter overrides (a config object; null: none)
  dvec3 offset{0.0};            ///< moves the tree (metres; a manifest's "offset", e.g. plot positions)
};

/// The inputs of a batch as a list of trees: files as given; directories by their skeleton
/// files (.json, .swc, .mat, .mtg, .csv, .tsv, and .txt named cyl_data*; sorted by name, not
/// recursing, hidden files skipped); manifests (a JSON file {"trees": [{"input": PATH, "name",
/// "config": PATH or {...}, "units", "columns", "format", "offset": [x, y, z]}, ...]}, paths
/// relative to the manifest) by their entries. Names are the file stems made safe
/// ([A-Za-z0-9._-]), with the extension and then a number added where two collide.
/// Throws InvalidInputError (a missing input, a malformed manifest, naming the entry) or
/// UsageError (no inputs).
std::vector<TreeJob> list_trees(const std::vector<std::string>& inputs, const ReadOptions& defaults);

/// Shard `index` of `count` (0 <= index < count): "I/N" as Slurm's array variables give it.
struct Shard {
  std::size_t index = 0;
  std::size_t count = 1;
};
/// Parses "I/N"; throws UsageError unless 0 <= I < N.
Shard parse_shard(const std::string& text);
/// The trees of one shard: every N-th tree from the I-th (round robin, so big and small
/// trees spread evenly when the list is sorted by name).
std::vector<TreeJob> take_shard(const std::vector<TreeJob>& trees, Shard shard);

/// 64-bit FNV-1a of `bytes` as 16 hex digits: detects changed inputs and configurations
/// (not a cryptographic hash).
std::string hash_hex(std::string_view bytes);

/// What became of one tree, as NAME.stats.json holds it.
struct TreeRecord {
  std::size_t index = 0;
  std::string name;
  std::string input;          ///< the input path as given
  std::string status;         ///< "ok", "check_failed" (mesh written, a check failed) or "failed"
  std::string error;          ///< why it failed (failed), or the failed checks (check_failed)
  std::string input_hash;     ///< hash_hex of the input file
  std::string config_hash;    ///< hash_hex of everything else that decides the output
  std::string mesh;           ///< mesh file name in the output folder (empty when failed)
  std::string thumbnail;      ///< PNG file name (empty when failed or off)
  nlohmann::json figures;     ///< skeleton, mesh and check figures (object; see docs/batch.md)

  [[nodiscard]] bool succeeded(bool strict) const { return status == "ok" || (!strict && status == "check_failed"); }
};
std::string record_to_json(const TreeRecord& record);
/// Reads NAME.stats.json; nullopt when it is missing or not a record.
std::optional<TreeRecord> read_record(const std::filesystem::path& path);

/// The file names of tree `name`'s outputs.
std::string record_file(const std::string& name);
std::string thumbnail_file(const std::string& name);

/// The summary table: one row per record, in the order given (CSV with a header).
std::string summary_csv(const std::vector<TreeRecord>& records);
/// The summary page: a table with each tree's thumbnail, status, figures and checks.
std::string summary_html(const std::vector<TreeRecord>& records, const std::string& title);
/// The names and indices of a summary CSV's rows (to find the records a shard wrote).
std::vector<std::pair<std::size_t, std::string>> summary_rows(const std::string& csv, const std::string& source);

/// The shard summary's path: OUTDIR/shards/I-of-N.csv.
std::filesystem::path shard_summary_path(const std::filesystem::path& outdir, Shard shard);

/// Merges the shard summaries of `outdir` (shards/I-of-N.csv for every I of one N) into
/// summary.csv and index.html, reading each tree's record. Throws InvalidInputError when a
/// shard or a record is missing, shards disagree on N, or a tree appears twice. Returns the
/// records in batch order.
std::vector<TreeRecord> merge_shards(const std::filesystem::path& outdir, const std::string& title);

/// Writes summary.csv and index.html for `records` into `outdir`.
void write_summary(const std::filesystem::path& outdir, const std::vector<TreeRecord>& records, const std::string& title);

}  // namespace sm::batch
