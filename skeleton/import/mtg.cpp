// OpenAlea (AMAPmod) MTG files: the multiscale tree graph's code, read for the geometry only.
//
// The MTG: section is one entity code per line, written in tab columns. A line's first
// element refers to an entity already read: with '^', the last entity of the latest line
// starting in the same column; without it, the last entity of the latest line one column to
// the left. Each element then refers to the one before it on the line: '/' a component (one
// scale finer), '<' a successor, '+' a branch, "<<" a range of successors (E1<<E5 is E1 < E2
// < ... < E5). The features in the columns after the code belong to the line's last entity.
// For a skeleton only "which entity comes from which" matters, whatever the scales: every
// entity with coordinates is a node, attached to the nearest entity before it with
// coordinates (the convention of OpenAlea's PlantFrame for digitised plants).

#include <algorithm>
#include <cctype>
#include <map>
#include <optional>
#include <unordered_map>

#include "core/errors.h"
#include "skeleton/import/formats.h"
#include "skeleton/import/text.h"

namespace sm {
namespace {

using import::normalize_name;

using import::trim;

constexpr std::size_t kNone = static_cast<std::size_t>(-1);
constexpr std::int64_t kMaxRange = 1'000'000;     // entities one "<<" range may create
constexpr std::size_t kMaxEntities = 5'000'000;  // in a file (about 100 bytes each; real plants: thousands)

struct Entity {
  std::string symbol;
  std::int64_t index = 0;
  std::size_t from = kNone;  ///< the entity this one was written after (its predecessor in the code)
  std::size_t line = 0;      ///< the line that wrote it
  bool has_point = false;
  dvec3 point{};
  double diameter = 0;  ///< 0: not given
};

struct Line {
  std::string_view text;
  std::size_t number;
};

/// The section headers of an MTG file, each at the start of a line.
bool starts_with(std::string_view s, std::string_view prefix) { return s.substr(0, prefix.size()) == prefix; }

std::vector<Line> split_lines(std::string_view text) {
  std::vector<Line> lines;
  import::for_each_line(text, [&](std::string_view line, std::size_t no) {
    lines.push_back({line, no});
    return true;
  });
  return lines;
}

/// Tab-separated cells with the 1-based character column of each.
std::vector<std::pair<std::string_view, std::size_t>> tab_cells(std::string_view line) {
  std::vector<std::pair<std::string_view, std::size_t>> cells;
  std::size_t i = 0;
  while (true) {
    const std::size_t j = line.find('\t', i);
    cells.emplace_back(line.substr(i, (j == std::string_view::npos ? line.size() : j) - i), i + 1);
    if (j == std::string_view::npos) break;
    i = j + 1;
  }
  return cells;
}

class MtgReader {
 public:
  MtgReader(std::string_view text, const std::string& name, const ColumnMap& columns)
      : name_(name), columns_(columns), lines_(split_lines(text)) {}

  RawSkeleton read() {
    std::size_t k = 0;
    // Comments (#) and blank lines may stand anywhere.
    auto content = [&](std::size_t i) {
      const std::string_view s = trim(lines_[i].text);
      return !s.empty() && s.front() != '#';
    };
    for (; k < lines_.size(); ++k) {
      if (!content(k)) continue;
      const std::string_view s = trim(lines_[k].text);
      if (starts_with(s, "CLASSES")) read_classes(k + 1);
      if (starts_with(s, "MTG")) break;
    }
    if (k == lines_.size()) {
      throw InvalidInputError(name_ +
                              ": no MTG: section (an MTG file has CODE:, CLASSES:, DESCRIPTION:, FEATURES: and MTG: sections)");
    }
    ++k;
    while (k < lines_.size() && !content(k)) ++k;
    if (k == lines_.size()) throw InvalidInputError(name_ + ": the MTG: section is empty");
    read_header(k);
    for (++k; k < lines_.size(); ++k) {
      if (content(k)) read_code_line(lines_[k]);
    }
    return build();
  }

 private:
  [[noreturn]] void fail(std::size_t line, std::size_t column, const std::string& what) const {
    throw InvalidInputError(name_ + ":" + std::to_string(line) + (column > 0 ? ":" + std::to_string(column) : "") +
                            ": " + what);
  }

  void read_classes(std::size_t k) {
    for (; k < lines_.size(); ++k) {
      const std::string_view s = trim(lines_[k].text);
      if (s.empty() || s.front() == '#') continue;
      if (starts_with(s, "SYMBOL")) continue;
      if (starts_with(s, "DESCRIPTION") || starts_with(s, "FEATURES") || starts_with(s, "MTG")) return;
      std::size_t e = 0;
      while (e < s.size() && s[e] != ' ' && s[e] != '\t') ++e;
      const std::string symbol(s.substr(0, e));
      if (symbol != "$") classes_.emplace(symbol, lines_[k].number);
    }
  }

  /// The ENTITY-CODE line: where the features start and which ones we use.
  void read_header(std::size_t k) {
    const Line& l = lines_[k];
    const std::string_view s = trim(l.text);
    if (!starts_with(s, "ENTITY-CODE") && !starts_with(s, "TOPO")) {
      fail(l.number, 1, "expected the ENTITY-CODE line naming the feature columns after MTG:, found " + import::quoted(s));
    }
    const auto cells = tab_cells(l.text);
    std::size_t first = 0;
    for (std::size_t c = 1; c < cells.size(); ++c) {
      if (!trim(cells[c].first).empty()) {
        first = c;
        break;
      }
    }
    if (first == 0) fail(l.number, 0, "the ENTITY-CODE line names no features (no coordinates XX, YY, ZZ)");
    feature_column_ = first;
    for (std::size_t c = first; c < cells.size(); ++c) feature_names_.emplace_back(trim(cells[c].first));
    auto find = [&](const char* field, std::initializer_list<const char*> defaults) -> std::optional<std::size_t> {
      for (const auto& [key, column] : columns_) {
        if (key != field) continue;
        for (std::size_t f = 0; f < feature_names_.size(); ++f)
          if (feature_names_[f] == column) return f;
        fail(l.number, 0, "--columns " + key + "=" + column + ": the ENTITY-CODE line has no feature \"" + column + "\"");
      }
      for (const char* d : defaults) {
        for (std::size_t f = 0; f < feature_names_.size(); ++f)
          if (normalize_name(feature_names_[f]) == d) return f;
      }
      return std::nullopt;
    };
    for (const auto& [key, column] : columns_) {
      if (key != "x" && key != "y" && key != "z" && key != "diameter" && key != "radius") {
        throw InvalidInputError("--columns: unknown field \"" + key + "\" for an MTG file (fields: x, y, z, diameter, radius)");
      }
    }
    x_ = find("x", {"xx", "x"});
    y_ = find("y", {"yy", "y"});
    z_ = find("z", {"zz", "z"});
    if (!x_ || !y_ || !z_) {
      fail(l.number, 0,
           "no coordinate features: the ENTITY-CODE line must name XX, YY and ZZ (or X, Y, Z; other names with "
           "--columns x=NAME,y=NAME,z=NAME)");
    }
    radius_ = find("radius", {"radius", "topradius", "rad"});
    diameter_ = find("diameter", {"topdia", "diameter", "topdiameter", "diam", "dia", "diametre", "botdia"});
    if (radius_ && diameter_) {
      // Both found by their usual names: a given mapping decides, else the diameter.
      const bool radius_given = std::any_of(columns_.begin(), columns_.end(), [](const auto& c) { return c.first == "radius"; });
      if (!radius_given) radius_.reset();
    }
    if (!radius_ && !diameter_) {
      fail(l.number, 0,
           "no diameter feature: the ENTITY-CODE line must name TopDia or Diameter (or a radius; other names with "
           "--columns diameter=NAME or radius=NAME)");
    }
  }

  std::size_t add_entity(std::string symbol, std::int64_t index, std::size_t from, std::size_t line) {
    if (entities_.size() >= kMaxEntities) fail(line, 0, "more than 5 million entities (ranges included)");
    Entity e;
    e.symbol = std::move(symbol);
    e.index = index;
    e.from = from;
    e.line = line;
    entities_.push_back(std::move(e));
    return entities_.size() - 1;
  }

  void read_code_line(const Line& l) {
    const std::string_view text = l.text;
    std::size_t col = 0;
    while (col < text.size() && text[col] == '\t') ++col;
    const auto cells = tab_cells(text);
    if (col >= feature_column_) {
      fail(l.number, col + 1, "the entity code starts in the feature columns (column " + std::to_string(col + 1) +
                                  " of the tab layout; the features start at " + std::to_string(feature_column_ + 1) + ")");
    }
    const std::string_view code = trim(cells[col].first);
    const std::size_t code_at = cells[col].second;  // character column of the code
    for (std::size_t c = col + 1; c < feature_column_ && c < cells.size(); ++c) {
      if (!trim(cells[c].first).empty()) {
        fail(l.number, cells[c].second,
             "a second entity code " + import::quoted(trim(cells[c].first)) + " on the line (one code per line, then the features)");
      }
    }
    std::size_t i = 0;
    std::size_t current = kNone;
    if (!code.empty() && code[0] == '^') {
      const auto it = last_at_column_.find(col);
      if (it == last_at_column_.end()) {
        fail(l.number, code_at, "'^' refers to the last entity of an earlier line starting in this column, and there is none");
      }
      current = it->second;
      i = 1;
    } else if (col > 0) {
      const auto it = last_at_column_.find(col - 1);
      if (it == last_at_column_.end()) {
        fail(l.number, code_at, "the line is indented with no line one column to its left to refer to");
      }
      current = it->second;
    }
    if (i >= code.size()) fail(l.number, code_at, "an empty entity code");
    while (i < code.size()) {
      const std::size_t at = code_at + i;
      std::string sep;
      if (code.compare(i, 2, "<<") == 0) {
        sep = "<<";
      } else if (code[i] == '<' || code[i] == '+' || code[i] == '/') {
        sep = std::string(1, code[i]);
      } else {
        fail(l.number, at, "expected '/', '<', '+' or \"<<\" before an entity, found " + import::quoted(code.substr(i, 1)));
      }
      i += sep.size();
      std::size_t j = i;
      while (j < code.size() && std::isalpha(static_cast<unsigned char>(code[j]))) ++j;
      const std::string symbol(code.substr(i, j - i));
      std::size_t d = j;
      while (d < code.size() && std::isdigit(static_cast<unsigned char>(code[d]))) ++d;
      if (symbol.empty()) fail(l.number, at, "expected a class symbol after " + import::quoted(sep));
      if (!classes_.empty() && classes_.count(symbol) == 0) {
        fail(l.number, code_at + i, "unknown class " + import::quoted(symbol) + " (not in the CLASSES: section)");
      }
      std::int64_t index = 0;
      if (d > j && !import::parse_integer(code.substr(j, d - j), index)) fail(l.number, code_at + j, "index out of range");
      if (sep == "<<") {
        if (current == kNone || entities_[current].symbol != symbol || entities_[current].index >= index) {
          fail(l.number, at,
               "a range \"<<" + symbol + std::to_string(index) +
                   "\" must follow an entity of the same class with a lower index");
        }
        if (index - entities_[current].index > kMaxRange) fail(l.number, at, "a range of more than a million entities");
        for (std::int64_t k = entities_[current].index + 1; k <= index; ++k) current = add_entity(symbol, k, current, l.number);
      } else {
        current = add_entity(symbol, index, current, l.number);
      }
      i = d;
    }
    read_features(l, cells, current);
    last_at_column_[col] = current;
    last_at_column_.erase(last_at_column_.upper_bound(col), last_at_column_.end());
  }

  void read_features(const Line& l, const std::vector<std::pair<std::string_view, std::size_t>>& cells, std::size_t e) {
    auto value = [&](std::optional<std::size_t> f, double& out) {
      if (!f) return false;
      const std::size_t c = feature_column_ + *f;
      if (c >= cells.size()) return false;
      const std::string_view s = trim(cells[c].first);
      if (s.empty()) return false;
      if (!import::parse_number(s, out)) {
        fail(l.number, cells[c].second, "feature " + feature_names_[*f] + ": " + import::quoted(s) + " is not a number");
      }
      return true;
    };
    dvec3 p;
    const int given = int(value(x_, p.x)) + int(value(y_, p.y)) + int(value(z_, p.z));
    if (given != 0 && given != 3) {
      fail(l.number, 0, "the entity has only " + std::to_string(given) + " of its 3 coordinates (" +
                            feature_names_[*x_] + ", " + feature_names_[*y_] + ", " + feature_names_[*z_] + ")");
    }
    Entity& ent = entities_[e];
    if (given == 3) {
      ent.has_point = true;
      ent.point = p;
    }
    double d = 0;
    if (radius_ && value(radius_, d)) ent.diameter = 2 * d;
    if (diameter_ && value(diameter_, d)) ent.diameter = d;
  }

  RawSkeleton build() const {
    RawSkeleton raw;
    raw.source = name_;
    raw.up_axis = UpAxis::z;
    std::vector<std::size_t> node(entities_.size(), kNone);
    std::vector<char> given;  // whether the node's diameter was in the file
    for (std::size_t e = 0; e < entities_.size(); ++e) {
      const Entity& ent = entities_[e];
      std::size_t from = ent.from;
      const std::size_t parent = from == kNone ? kNone : node[from];
      if (!ent.has_point) {
        node[e] = parent;  // its descendants attach to its nearest ancestor with a point
        continue;
      }
      if (parent != kNone && raw.position[parent] == ent.point) {
        node[e] = parent;  // the same point as its parent (an axis and its first component)
        if (ent.diameter > 0 || ent.diameter < 0) {
          raw.radius[parent] = 0.5 * ent.diameter;
          given[parent] = 1;
        }
        continue;
      }
      node[e] = raw.size();
      raw.id.push_back(std::int64_t(raw.size()));
      raw.parent_id.push_back(parent == kNone ? -1 : std::int64_t(parent));
      raw.position.push_back(ent.point);
      raw.radius.push_back(0.5 * ent.diameter);
      given.push_back(ent.diameter != 0);
      raw.where.push_back("line " + std::to_string(ent.line) + " (" + ent.symbol + std::to_string(ent.index) + ")");
    }
    if (raw.size() == 0) throw InvalidInputError(name_ + ": no entity has coordinates");
    // Nodes without a diameter take their parent's (parents come first); a root without one
    // takes the first diameter in the file.
    const auto first = std::find(given.begin(), given.end(), 1);
    if (first == given.end()) {
      throw InvalidInputError(name_ + ": no entity with coordinates has a diameter (" +
                              feature_names_[diameter_ ? *diameter_ : *radius_] + ")");
    }
    const double fallback = raw.radius[std::size_t(first - given.begin())];
    for (std::size_t i = 0; i < raw.size(); ++i) {
      if (given[i]) continue;
      raw.radius[i] = raw.parent_id[i] < 0 ? fallback : raw.radius[std::size_t(raw.parent_id[i])];
    }
    return raw;
  }

  const std::string& name_;
  const ColumnMap& columns_;
  std::vector<Line> lines_;
  std::map<std::string, std::size_t> classes_;  ///< symbol -> line of its definition
  std::size_t feature_column_ = 0;              ///< tab column of the first feature
  std::vector<std::string> feature_names_;
  std::optional<std::size_t> x_, y_, z_, diameter_, radius_;  ///< feature indices
  std::vector<Entity> entities_;
  std::map<std::size_t, std::size_t> last_at_column_;  ///< tab column -> last entity of its latest line
};

}  // namespace

RawSkeleton parse_mtg(std::string_view text, const std::string& name, const ColumnMap& columns) {
  if (trim(text).empty()) throw InvalidInputError(name + ": the file is empty");
  return MtgReader(text, name, columns).read();
}

}  // namespace sm
