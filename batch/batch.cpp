#include "batch/batch.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>

#include "core/errors.h"
#include "core/file_io.h"
#include "core/input_limits.h"

namespace sm::batch {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

bool is_skeleton_file(const fs::path& p) {
  const std::string ext = extension_of(p);
  const std::string name = p.filename().string();
  if (name.empty() || name[0] == '.') return false;
  if (ext == "txt") return name.rfind("cyl_data", 0) == 0;
  return ext == "json" || ext == "swc" || ext == "mat" || ext == "mtg" || ext == "csv" || ext == "tsv";
}

std::string safe_name(const std::string& s) {
  std::string out;
  for (const char ch : s) out += std::isalnum(static_cast<unsigned char>(ch)) || ch == '.' || ch == '-' || ch == '_' ? ch : '_';
  if (out.empty() || out[0] == '.') out.insert(0, "tree");
  return out;
}

/// A manifest: a JSON object with a "trees" array (nullopt when `path` is no manifest).
std::optional<json> manifest_of(const fs::path& path) {
  if (extension_of(path) != "json") return std::nullopt;
  const std::string text = read_file(path);
  if (text.find("\"trees\"") == std::string::npos) return std::nullopt;
  check_json_nesting(text, path.string());
  json doc = json::parse(text, nullptr, false);
  if (doc.is_discarded() || !doc.is_object() || !doc.contains("trees") || doc.contains("nodes")) return std::nullopt;
  return doc;
}

std::string text_of(const json& j, const char* key, const std::string& where) {
  const auto it = j.find(key);
  if (it == j.end()) return {};
  if (!it->is_string()) throw InvalidInputError(where + ": \"" + key + "\" must be a string");
  return it->get<std::string>();
}

void add_manifest(const fs::path& path, const json& doc, const ReadOptions& defaults, std::vector<TreeJob>& out) {
  const std::string name = path.string();
  const json& trees = doc["trees"];
  if (!trees.is_array()) throw InvalidInputError(name + ": \"trees\" must be an array of entries");
  const fs::path base = path.parent_path();
  for (std::size_t k = 0; k < trees.size(); ++k) {
    const json& e = trees[k];
    const std::string where = name + ": trees[" + std::to_string(k) + "]";
    if (e.is_string()) {
      out.push_back({0, "", base / e.get<std::string>(), defaults, nullptr, dvec3(0.0)});
      continue;
    }
    if (!e.is_object()) throw InvalidInputError(where + ": an entry is a path or an object with \"input\"");
    static const std::set<std::string> keys{"input", "name", "config", "units", "columns", "format", "offset"};
    for (const auto& [key, value] : e.items()) {
      if (keys.count(key) == 0) {
        throw InvalidInputError(where + ": unknown key \"" + key + "\" (input, name, config, units, columns, format, offset)");
      }
    }
    TreeJob job;
    const std::string input = text_of(e, "input", where);
    if (input.empty()) throw InvalidInputError(where + ": missing \"input\"");
    job.input = base / input;
    job.name = text_of(e, "name", where);
    job.read = defaults;
    try {
      if (const std::string f = text_of(e, "format", where); !f.empty()) job.read.format = parse_format_name(f);
      if (const std::string c = text_of(e, "columns", where); !c.empty()) job.read.columns = parse_column_map(c);
      if (const std::string u = text_of(e, "units", where); !u.empty()) {
        std::tie(job.read.length_unit, job.read.thickness_unit) = parse_units(u);
      }
    } catch (const UsageError& err) {
      throw InvalidInputError(where + ": " + err.what());
    }
    if (const auto c = e.find("config"); c != e.end()) {
      if (c->is_string()) {
        const fs::path cfg = base / c->get<std::string>();
        const std::string text = read_file(cfg);
        check_json_nesting(text, cfg.string());
        json parsed = json::parse(text, nullptr, false);
        if (parsed.is_discarded() || !parsed.is_object()) {
          throw InvalidInputError(where + ": config " + cfg.string() + " is not a JSON object");
        }
        job.config = std::move(parsed);
      } else if (c->is_object()) {
        job.config = *c;
      } else if (!c->is_null()) {
        throw InvalidInputError(where + ": \"config\" must be a file name or an object");
      }
    }
    if (const auto o = e.find("offset"); o != e.end()) {
      if (!o->is_array() || o->size() != 3 || !std::all_of(o->begin(), o->end(), [](const json& v) { return v.is_number(); })) {
        throw InvalidInputError(where + ": \"offset\" must be [x, y, z] in metres");
      }
      job.offset = dvec3((*o)[0].get<double>(), (*o)[1].get<double>(), (*o)[2].get<double>());
      if (!std::isfinite(job.offset.x) || !std::isfinite(job.offset.y) || !std::isfinite(job.offset.z)) {
        throw InvalidInputError(where + ": \"offset\" must be finite");
      }
    }
    out.push_back(std::move(job));
  }
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string out = "\"";
  for (const char ch : s) {
    if (ch == '"') out += '"';
    out += ch == '\n' || ch == '\r' ? ' ' : ch;
  }
  return out + "\"";
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (const char ch : s) {
    switch (ch) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += ch;
    }
  }
  return out;
}

/// A figure from the record for the summary ("" when absent): integers as they are, other
/// numbers with 4 significant digits, booleans as yes/no.
std::string figure(const json& figures, const char* group, const char* key) {
  const auto g = figures.find(group);
  if (g == figures.end() || !g->is_object()) return {};
  const auto it = g->find(key);
  if (it == g->end()) return {};
  if (it->is_boolean()) return it->get<bool>() ? "yes" : "no";
  if (it->is_number_integer() || it->is_number_unsigned()) return it->dump();
  if (it->is_number_float()) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4g", it->get<double>());
    return buf;
  }
  if (it->is_string()) return it->get<std::string>();
  return {};
}

struct Column {
  const char* header;
  const char* group;
  const char* key;
};
const std::vector<Column>& figure_columns() {
  static const std::vector<Column> c{
      {"input_nodes", "skeleton", "input_nodes"},      {"nodes", "skeleton", "nodes"},
      {"triangles", "mesh", "triangles"},              {"vertices", "mesh", "vertices"},
      {"closed", "checks", "closed"},                  {"manifold", "checks", "manifold"},
      {"oriented", "checks", "oriented"},              {"components", "checks", "components"},
      {"genus", "checks", "genus"},                    {"self_intersections", "checks", "self_intersecting_pairs"},
      {"fidelity_p95", "checks", "fidelity_p95"},      {"thick_nodes", "checks", "thick_nodes"},
      {"thick_nodes_inside", "checks", "thick_nodes_inside"}, {"volume_m3", "checks", "volume"},
  };
  return c;
}

}  // namespace

std::vector<TreeJob> list_trees(const std::vector<std::string>& inputs, const ReadOptions& defaults) {
  if (inputs.empty()) throw UsageError("batch: no inputs (files, directories or manifests)");
  std::vector<TreeJob> trees;
  for (const std::string& in : inputs) {
    const fs::path p(in);
    std::error_code ec;
    if (fs::is_directory(p, ec)) {
      std::vector<fs::path> files;
      for (const auto& entry : fs::directory_iterator(p, ec)) {
        if (entry.is_regular_file(ec) && is_skeleton_file(entry.path())) files.push_back(entry.path());
      }
      if (ec) throw IoError("cannot list " + in + ": " + ec.message());
      std::sort(files.begin(), files.end());
      for (const fs::path& f : files) trees.push_back({0, "", f, defaults, nullptr, dvec3(0.0)});
      continue;
    }
    if (!fs::exists(p, ec)) throw IoError("cannot open " + in + ": no such file or directory");
    if (const auto manifest = manifest_of(p)) {
      add_manifest(p, *manifest, defaults, trees);
    } else {
      trees.push_back({0, "", p, defaults, nullptr, dvec3(0.0)});
    }
  }
  if (trees.empty()) throw InvalidInputError("batch: the inputs hold no skeleton files");
  // Unique names, in order: the stem, then stem_ext, then stem_ext_2, ...
  std::set<std::string> used;
  for (std::size_t i = 0; i < trees.size(); ++i) {
    TreeJob& t = trees[i];
    t.index = i;
    std::string name = safe_name(t.name.empty() ? t.input.stem().string() : t.name);
    if (used.count(name) != 0 && t.name.empty() && !extension_of(t.input).empty()) {
      name += '_';
      name += extension_of(t.input);
    }
    const std::string stem = name;
    for (int k = 2; used.count(name) != 0; ++k) name = stem + "_" + std::to_string(k);
    used.insert(name);
    t.name = name;
  }
  return trees;
}

Shard parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  Shard s;
  try {
    if (slash == std::string::npos) throw std::invalid_argument("");
    std::size_t used = 0;
    s.index = std::stoul(text.substr(0, slash), &used);
    if (used != slash) throw std::invalid_argument("");
    const std::string n = text.substr(slash + 1);
    s.count = std::stoul(n, &used);
    if (used != n.size()) throw std::invalid_argument("");
  } catch (const std::exception&) {
    throw UsageError("--shard " + text + ": expected I/N, e.g. --shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT");
  }
  if (s.count == 0 || s.index >= s.count) {
    throw UsageError("--shard " + text + ": I must be 0 to N-1 (an array --array=0-" +
                     std::to_string(s.count == 0 ? 0 : s.count - 1) + ")");
  }
  return s;
}

std::vector<TreeJob> take_shard(const std::vector<TreeJob>& trees, Shard shard) {
  std::vector<TreeJob> out;
  for (const TreeJob& t : trees)
    if (t.index % shard.count == shard.index) out.push_back(t);
  return out;
}

std::string hash_hex(std::string_view bytes) {
  std::uint64_t h = 0xcbf29ce484222325ull;
  for (const char c : bytes) {
    h ^= static_cast<unsigned char>(c);
    h *= 0x100000001b3ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

std::string record_file(const std::string& name) { return name + ".stats.json"; }
std::string thumbnail_file(const std::string& name) { return name + ".png"; }

std::string record_to_json(const TreeRecord& r) {
  json j;
  j["index"] = r.index;
  j["name"] = r.name;
  j["input"] = r.input;
  j["status"] = r.status;
  if (!r.error.empty()) j["error"] = r.error;
  j["input_hash"] = r.input_hash;
  j["config_hash"] = r.config_hash;
  j["mesh"] = r.mesh;
  j["thumbnail"] = r.thumbnail;
  j["figures"] = r.figures.is_object() ? r.figures : json::object();
  return j.dump(2) + "\n";
}

std::optional<TreeRecord> read_record(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  json j;
  try {
    const std::string text = read_file(path);
    check_json_nesting(text, path.string());
    j = json::parse(text, nullptr, false);
  } catch (const Error&) {
    return std::nullopt;  // unreadable or absurd: not one of our records, the tree is redone
  }
  if (j.is_discarded() || !j.is_object()) return std::nullopt;
  try {
    TreeRecord r;
    r.index = j.at("index").get<std::size_t>();
    r.name = j.at("name").get<std::string>();
    r.input = j.at("input").get<std::string>();
    r.status = j.at("status").get<std::string>();
    r.error = j.value("error", std::string());
    r.input_hash = j.at("input_hash").get<std::string>();
    r.config_hash = j.at("config_hash").get<std::string>();
    r.mesh = j.at("mesh").get<std::string>();
    r.thumbnail = j.at("thumbnail").get<std::string>();
    r.figures = j.at("figures");
    return r;
  } catch (const json::exception&) {
    return std::nullopt;
  }
}

std::string summary_csv(const std::vector<TreeRecord>& records) {
  std::string out = "index,name,input,status";
  for (const Column& c : figure_columns()) out += std::string(",") + c.header;
  out += ",mesh,error\n";
  for (const TreeRecord& r : records) {
    // Appended piece by piece: GCC 12 warns (-Wrestrict, a false positive) on "," + string.
    for (const std::string& f : {std::to_string(r.index), csv_field(r.name), csv_field(r.input), r.status}) {
      out += f;
      out += ',';
    }
    for (const Column& c : figure_columns()) {
      out += csv_field(figure(r.figures, c.group, c.key));
      out += ',';
    }
    out += csv_field(r.mesh);
    out += ',';
    out += csv_field(r.error);
    out += '\n';
  }
  return out;
}

std::vector<std::pair<std::size_t, std::string>> summary_rows(const std::string& csv, const std::string& source) {
  // Our own CSV: the first two fields are an index and a name without commas or quotes.
  std::vector<std::pair<std::size_t, std::string>> rows;
  std::size_t start = csv.find('\n');
  if (start == std::string::npos || csv.rfind("index,name,", 0) != 0) {
    throw InvalidInputError(source + ": not a batch summary (no \"index,name,...\" header)");
  }
  std::size_t line = 1;
  for (++start; start < csv.size();) {
    std::size_t end = csv.find('\n', start);
    if (end == std::string::npos) end = csv.size();
    ++line;
    const std::string row = csv.substr(start, end - start);
    start = end + 1;
    if (row.empty()) continue;
    const auto c1 = row.find(',');
    const auto c2 = c1 == std::string::npos ? c1 : row.find(',', c1 + 1);
    std::size_t index = 0, used = 0;
    try {
      index = std::stoul(row.substr(0, c1), &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (c2 == std::string::npos || used != c1) {
      throw InvalidInputError(source + ":" + std::to_string(line) + ": not a summary row");
    }
    rows.emplace_back(index, row.substr(c1 + 1, c2 - c1 - 1));
  }
  return rows;
}

std::string summary_html(const std::vector<TreeRecord>& records, const std::string& title) {
  std::size_t ok = 0, flawed = 0, failed = 0;
  for (const TreeRecord& r : records) {
    ok += r.status == "ok";
    flawed += r.status == "check_failed";
    failed += r.status == "failed";
  }
  std::string h =
      "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>" + html_escape(title) +
      "</title>\n<style>body{font-family:sans-serif;margin:1em}table{border-collapse:collapse}"
      "td,th{border:1px solid #ccc;padding:2px 6px;text-align:right;vertical-align:middle}"
      "td.l,th.l{text-align:left}tr.failed{background:#fdd}tr.check_failed{background:#ffd}"
      "img{width:128px;height:128px;display:block}</style></head><body>\n<h1>" +
      html_escape(title) + "</h1>\n<p>" + std::to_string(records.size()) + " trees: " + std::to_string(ok) + " ok, " +
      std::to_string(flawed) + " meshed but failing a check, " + std::to_string(failed) +
      " failed. Figures per tree in NAME.stats.json, all of them in <a href=\"summary.csv\">summary.csv</a>.</p>\n"
      "<table>\n<tr><th></th><th class=\"l\">tree</th><th class=\"l\">status</th>";
  for (const Column& c : figure_columns()) h += "<th>" + std::string(c.header) + "</th>";
  h += "<th class=\"l\">error or failed checks</th></tr>\n";
  for (const TreeRecord& r : records) {
    h += "<tr class=\"" + r.status + "\"><td>";
    if (!r.thumbnail.empty()) {
      const std::string link = r.mesh.empty() ? r.thumbnail : r.mesh;
      h += "<a href=\"" + html_escape(link) + "\"><img src=\"" + html_escape(r.thumbnail) + "\" alt=\"" +
           html_escape(r.name) + "\"></a>";
    }
    h += "</td><td class=\"l\"><a href=\"" + html_escape(record_file(r.name)) + "\">" + html_escape(r.name) +
         "</a><br><small>" + html_escape(r.input) + "</small></td><td class=\"l\">" + r.status + "</td>";
    for (const Column& c : figure_columns()) h += "<td>" + html_escape(figure(r.figures, c.group, c.key)) + "</td>";
    h += "<td class=\"l\">" + html_escape(r.error) + "</td></tr>\n";
  }
  h += "</table>\n</body></html>\n";
  return h;
}

fs::path shard_summary_path(const fs::path& outdir, Shard shard) {
  return outdir / "shards" / (std::to_string(shard.index) + "-of-" + std::to_string(shard.count) + ".csv");
}

void write_summary(const fs::path& outdir, const std::vector<TreeRecord>& records, const std::string& title) {
  write_file_atomically(outdir / "summary.csv", summary_csv(records));
  write_file_atomically(outdir / "index.html", summary_html(records, title));
}

std::vector<TreeRecord> merge_shards(const fs::path& outdir, const std::string& title) {
  const fs::path dir = outdir / "shards";
  std::error_code ec;
  std::map<std::size_t, std::set<std::size_t>> found;  // N -> shard indices
  if (fs::is_directory(dir, ec)) {
    for (const auto& entry : fs::directory_iterator(dir, ec)) {
      unsigned long i = 0, n = 0;
      char tail = 0;
      const std::string f = entry.path().filename().string();
      if (std::sscanf(f.c_str(), "%lu-of-%lu.cs%c", &i, &n, &tail) == 3 && tail == 'v' && i < n) found[n].insert(i);
    }
  }
  if (found.empty()) throw InvalidInputError(dir.string() + ": no shard summaries (I-of-N.csv) to merge");
  if (found.size() > 1) {
    throw InvalidInputError(dir.string() + ": shard summaries of different runs (N = " + std::to_string(found.begin()->first) +
                            " and " + std::to_string(found.rbegin()->first) + "); remove the stale ones");
  }
  const std::size_t n = found.begin()->first;
  std::string missing;
  for (std::size_t i = 0; i < n; ++i)
    if (found.begin()->second.count(i) == 0) missing += (missing.empty() ? "" : ", ") + std::to_string(i);
  if (!missing.empty()) {
    throw InvalidInputError(dir.string() + ": shard" + (missing.find(',') != std::string::npos ? "s " : " ") + missing +
                            " of " + std::to_string(n) + " missing (not run, or not finished)");
  }
  std::map<std::size_t, TreeRecord> by_index;
  for (std::size_t i = 0; i < n; ++i) {
    const fs::path csv = shard_summary_path(outdir, {i, n});
    for (const auto& [index, name] : summary_rows(read_file(csv), csv.string())) {
      auto record = read_record(outdir / record_file(name));
      if (!record) throw InvalidInputError(csv.string() + ": tree " + name + " has no record " + record_file(name));
      if (by_index.count(index) != 0) {
        throw InvalidInputError(csv.string() + ": tree " + std::to_string(index) + " (" + name + ") is in two shards");
      }
      by_index.emplace(index, std::move(*record));
    }
  }
  std::vector<TreeRecord> records;
  for (auto& [index, r] : by_index) records.push_back(std::move(r));
  write_summary(outdir, records, title);
  return records;
}

}  // namespace sm::batch
