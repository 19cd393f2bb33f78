// Cylinder tables: CSV with a header (SimpleForest, aRchi, rTwig, R exports of TreeQSM) and
// TreeQSM's headerless text export. Columns are found by name; see formats.h.

#include <algorithm>
#include <array>
#include <optional>

#include "core/errors.h"
#include "skeleton/import/cylinders.h"
#include "skeleton/import/formats.h"
#include "skeleton/import/text.h"

namespace sm {
namespace {

using import::normalize_name;

using import::trim;

/// The fields a cylinder table can have, each with the names it goes by (normalized: lower
/// case, letters and digits). The first name is the field's own, used by --columns.
struct Field {
  const char* key;
  std::vector<const char*> names;
};
enum F { id, parent, extension, sx, sy, sz, ex, ey, ez, ax, ay, az, length, radius, diameter, kFields };
const std::array<Field, kFields>& fields() {
  static const std::array<Field, kFields> f{{
      {"id", {"id", "cylid", "cylinderid", "idcyl", "cylinder", "cyl"}},
      {"parent", {"parent", "parentid", "parentcylid", "parentcyl", "parentcylinder", "idparent", "parentcylinderid"}},
      {"extension", {"extension", "extensionid", "ext", "extid", "extensioncyl", "extensioncylid", "next", "nextid"}},
      {"start_x", {"startx", "xstart", "startpointx", "sx", "start1", "x1"}},
      {"start_y", {"starty", "ystart", "startpointy", "sy", "start2", "y1"}},
      {"start_z", {"startz", "zstart", "startpointz", "sz", "start3", "z1"}},
      {"end_x", {"endx", "xend", "endpointx", "ex", "end1", "x2"}},
      {"end_y", {"endy", "yend", "endpointy", "ey", "end2", "y2"}},
      {"end_z", {"endz", "zend", "endpointz", "ez", "end3", "z2"}},
      {"axis_x", {"axisx", "xaxis", "axisdirectionx", "directionx", "dirx", "axis1", "dx"}},
      {"axis_y", {"axisy", "yaxis", "axisdirectiony", "directiony", "diry", "axis2", "dy"}},
      {"axis_z", {"axisz", "zaxis", "axisdirectionz", "directionz", "dirz", "axis3", "dz"}},
      {"length", {"length", "len", "cyllength", "lengthcyl", "lengthm"}},
      {"radius", {"radius", "radiuscyl", "rad", "cylradius", "radiusm", "r"}},
      {"diameter", {"diameter", "diametercyl", "diam", "dia", "cyldiameter", "diameterm"}},
  }};
  return f;
}

struct Cell {
  std::string_view text;
  std::size_t column = 0;  ///< 1-based character column where the field starts
};

/// Splits one line at `delim` (' ' = runs of blanks), honouring double quotes ("a,b" is one
/// field; the quotes are dropped) and trimming blanks around fields.
void split(std::string_view line, char delim, std::vector<Cell>& out) {
  out.clear();
  std::size_t i = 0;
  const std::size_t n = line.size();
  auto blank = [](char ch) { return ch == ' ' || ch == '\t'; };
  if (delim == ' ') {
    while (i < n) {
      while (i < n && blank(line[i])) ++i;
      if (i >= n) break;
      std::size_t j = i;
      while (j < n && !blank(line[j])) ++j;
      std::string_view tok = line.substr(i, j - i);
      if (tok.size() >= 2 && tok.front() == '"' && tok.back() == '"') tok = tok.substr(1, tok.size() - 2);
      out.push_back({tok, i + 1});
      i = j;
    }
    return;
  }
  while (true) {
    while (i < n && blank(line[i]) && line[i] != delim) ++i;
    const std::size_t col = i + 1;
    std::string_view tok;
    if (i < n && line[i] == '"') {
      const std::size_t close = line.find('"', i + 1);
      const std::size_t stop = close == std::string_view::npos ? n : close;
      tok = line.substr(i + 1, stop - i - 1);
      i = close == std::string_view::npos ? n : close + 1;
      while (i < n && line[i] != delim) ++i;
    } else {
      std::size_t j = line.find(delim, i);
      if (j == std::string_view::npos) j = n;
      tok = trim(line.substr(i, j - i));
      i = j;
    }
    out.push_back({tok, col});
    if (i >= n) break;
    ++i;  // past the delimiter
  }
}

/// The delimiter of a header line: the most frequent of ',', ';', tab outside quotes, else blanks.
char sniff_delimiter(std::string_view line) {
  std::size_t comma = 0, semi = 0, tab = 0;
  bool quote = false;
  for (const char ch : line) {
    if (ch == '"') quote = !quote;
    if (quote) continue;
    comma += ch == ',';
    semi += ch == ';';
    tab += ch == '\t';
  }
  if (comma == 0 && semi == 0 && tab == 0) return ' ';
  if (comma >= semi && comma >= tab) return ',';
  return semi >= tab ? ';' : '\t';
}

bool is_number(std::string_view s) {
  double d = 0;
  return import::parse_number(s, d);
}

/// Reads the numbers of data lines, naming the line, the column and the field in errors.
class TableReader {
 public:
  explicit TableReader(const std::string& name) : name_(name) {}

  std::string at(std::size_t line, const Cell& cell, const std::string& column) const {
    return name_ + ":" + std::to_string(line) + ":" + std::to_string(cell.column) + ": " + column;
  }
  double number(std::size_t line, const Cell& cell, const std::string& column) const {
    double d = 0;
    if (!import::parse_number(cell.text, d))
      throw InvalidInputError(at(line, cell, column) + ": " + import::quoted(cell.text) + " is not a number");
    return d;
  }
  std::int64_t integer(std::size_t line, const Cell& cell, const std::string& column) const {
    std::int64_t v = 0;
    if (!import::parse_integer(cell.text, v))
      throw InvalidInputError(at(line, cell, column) + ": " + import::quoted(cell.text) + " is not an integer");
    return v;
  }

 private:
  const std::string& name_;
};

/// TreeQSM's cyl_data text: radius, length, start (3), axis (3), parent, extension, ...
RawSkeleton parse_treeqsm_text(std::string_view text, const std::string& name) {
  CylinderTable t;
  t.source = name;
  TableReader rd(name);
  std::vector<Cell> cells;
  std::size_t row = 0;
  static const char* names[10] = {"radius", "length", "start x", "start y", "start z",
                                  "axis x", "axis y", "axis z", "parent", "extension"};
  import::for_each_line(text, [&](std::string_view line, std::size_t no) {
    if (trim(line).empty() || trim(line).front() == '#') return true;
    split(line, sniff_delimiter(line), cells);
    if (cells.size() < 10) {
      throw InvalidInputError(name + ":" + std::to_string(no) + ": " + std::to_string(cells.size()) +
                              " fields, a TreeQSM cylinder line has at least 10 (radius, length, start x y z, "
                              "axis x y z, parent, extension)");
    }
    double v[8];
    for (int k = 0; k < 8; ++k) v[k] = rd.number(no, cells[std::size_t(k)], names[k]);
    ++row;
    const dvec3 start(v[2], v[3], v[4]), axis(v[5], v[6], v[7]);
    t.id.push_back(std::int64_t(row));
    t.parent.push_back(rd.integer(no, cells[8], names[8]));
    t.extension.push_back(rd.integer(no, cells[9], names[9]));
    t.start.push_back(start);
    t.end.push_back(start + v[1] * axis);
    t.radius.push_back(v[0]);
    t.where.push_back("line " + std::to_string(no) + " (cylinder " + std::to_string(row) + ")");
    return true;
  });
  return cylinders_to_skeleton(t);
}

}  // namespace

std::string known_column_fields() {
  std::string s;
  for (const Field& f : fields()) s += (s.empty() ? "" : ", ") + std::string(f.key);
  return s + " (tables); x, y, z, diameter, radius (MTG)";
}

RawSkeleton parse_cylinder_table(std::string_view text, const std::string& name, const ColumnMap& columns) {
  // The first line that is neither blank nor a comment decides: names -> header, numbers ->
  // TreeQSM's text export.
  std::string_view header;
  std::size_t header_line = 0;
  import::for_each_line(text, [&](std::string_view line, std::size_t no) {
    const std::string_view s = trim(line);
    if (s.empty() || s.front() == '#') return true;
    header = line;
    header_line = no;
    return false;
  });
  if (header_line == 0) throw InvalidInputError(name + ": the file is empty");
  const char delim = sniff_delimiter(header);
  std::vector<Cell> cells;
  split(header, delim, cells);
  if (std::all_of(cells.begin(), cells.end(), [](const Cell& c) { return is_number(c.text); })) {
    if (!columns.empty()) {
      throw InvalidInputError(name + ":" + std::to_string(header_line) +
                              ": --columns needs a header line naming the columns; this table has none");
    }
    return parse_treeqsm_text(text, name);
  }
  if (header.find('\0') != std::string_view::npos || header.find('\x01') != std::string_view::npos)
    throw InvalidInputError(name + ": binary data, not a cylinder table");

  // Column of each field: a --columns name first, then the usual names.
  std::array<std::optional<std::size_t>, kFields> col;
  std::vector<std::string> header_names;
  for (const Cell& c : cells) header_names.push_back(normalize_name(c.text));
  for (const auto& [key, column] : columns) {
    const auto f = std::find_if(fields().begin(), fields().end(), [&key = key](const Field& x) { return x.key == key; });
    if (f == fields().end()) {
      throw InvalidInputError("--columns: unknown field \"" + key + "\" (fields: " + known_column_fields() + ")");
    }
    const auto k = std::find_if(cells.begin(), cells.end(), [&column = column](const Cell& c) { return c.text == column; });
    if (k == cells.end()) {
      throw InvalidInputError(name + ":" + std::to_string(header_line) + ": --columns " + key + "=" + column +
                              ": the header has no column \"" + column + "\"");
    }
    col[std::size_t(f - fields().begin())] = std::size_t(k - cells.begin());
  }
  for (std::size_t f = 0; f < kFields; ++f) {
    if (col[f]) continue;
    for (const char* candidate : fields()[f].names) {
      const auto k = std::find(header_names.begin(), header_names.end(), candidate);
      if (k != header_names.end()) {
        col[f] = std::size_t(k - header_names.begin());
        break;
      }
    }
  }
  const std::string head = name + ":" + std::to_string(header_line) + ": ";
  auto need = [&](std::initializer_list<F> fs, const char* what) {
    for (const F f : fs) {
      if (!col[f]) {
        std::string looked;
        for (const char* c : fields()[f].names) looked += (looked.empty() ? "" : ", ") + std::string(c);
        throw InvalidInputError(head + "no column for the " + what + " (" + fields()[f].key + "; looked for " + looked +
                                " in any case, ignoring _ and .; name it with --columns " + fields()[f].key + "=NAME)");
      }
    }
  };
  need({sx, sy, sz}, "cylinder start");
  need({parent}, "parent cylinder");
  if (!col[radius] && !col[diameter]) need({radius}, "radius");
  const bool by_end = col[ex] && col[ey] && col[ez];
  if (!by_end) {
    if (!col[ax] && !col[ay] && !col[az] && !col[length]) need({ex, ey, ez}, "cylinder end (or axis and length)");
    need({ax, ay, az}, "cylinder axis");
    need({length}, "cylinder length");
  }

  CylinderTable t;
  t.source = name;
  TableReader rd(name);
  std::size_t row = 0;
  const std::size_t width = cells.size();
  const bool has_ext = col[extension].has_value();
  auto label = [&](F f) { return "column " + import::quoted(cells[*col[f]].text); };
  std::vector<std::string> labels(kFields);
  for (std::size_t f = 0; f < kFields; ++f)
    if (col[f]) labels[f] = label(F(f));
  std::vector<Cell> row_cells;
  import::for_each_line(text, [&](std::string_view line, std::size_t no) {
    if (no <= header_line) return true;
    const std::string_view s = trim(line);
    if (s.empty() || s.front() == '#') return true;
    split(line, delim, row_cells);
    if (row_cells.size() != width) {
      throw InvalidInputError(name + ":" + std::to_string(no) + ": " + std::to_string(row_cells.size()) +
                              " fields, the header (line " + std::to_string(header_line) + ") has " +
                              std::to_string(width));
    }
    ++row;
    auto cell = [&](F f) -> const Cell& { return row_cells[*col[f]]; };
    auto num = [&](F f) { return rd.number(no, cell(f), labels[f]); };
    const dvec3 start(num(sx), num(sy), num(sz));
    dvec3 end;
    if (by_end) {
      end = dvec3(num(ex), num(ey), num(ez));
    } else {
      const dvec3 axis(num(ax), num(ay), num(az));
      const double len = glm::length(axis);
      // An axis given with its length (not a unit vector) is taken as the whole cylinder.
      end = start + (len > 0 ? axis / len : axis) * num(length);
    }
    const double r = col[radius] ? num(radius) : 0.5 * num(diameter);
    const std::int64_t cyl_id = col[id] ? rd.integer(no, cell(id), labels[id]) : std::int64_t(row);
    // R writes NA (and some tools nothing) for the root's parent.
    const std::string_view p = cell(parent).text;
    const std::int64_t parent_id = p.empty() || p == "NA" || p == "NaN" ? -1 : rd.integer(no, cell(parent), labels[parent]);
    std::int64_t ext = -1;
    if (has_ext) {
      const std::string_view e = cell(extension).text;
      if (!(e.empty() || e == "NA" || e == "NaN")) ext = rd.integer(no, cell(extension), labels[extension]);
    }
    t.id.push_back(cyl_id);
    t.parent.push_back(parent_id);
    if (has_ext) t.extension.push_back(ext);
    t.start.push_back(start);
    t.end.push_back(end);
    t.radius.push_back(r);
    t.where.push_back("line " + std::to_string(no) + " (cylinder id " + std::to_string(cyl_id) + ")");
    return true;
  });
  if (t.size() == 0) throw InvalidInputError(head + "a header but no cylinders");
  return cylinders_to_skeleton(t);
}

}  // namespace sm
