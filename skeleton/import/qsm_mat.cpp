// TreeQSM MATLAB files through libmatio (see formats.h).

#include <cmath>
#include <cstdio>
#include <cstring>
#include <utility>
#include <vector>
#include <memory>

#include <matio.h>

#include "core/errors.h"
#include "core/file_io.h"
#include "skeleton/import/cylinders.h"
#include "skeleton/import/formats.h"
#include "skeleton/import/mat_check.h"

namespace sm {
namespace {

struct MatCloser {
  void operator()(mat_t* m) const { Mat_Close(m); }
};
struct VarFreer {
  void operator()(matvar_t* v) const { Mat_VarFree(v); }
};
using MatFile = std::unique_ptr<mat_t, MatCloser>;
using MatVar = std::unique_ptr<matvar_t, VarFreer>;

/// Field `field` of the first element of struct `s`, or null when there is none. libmatio
/// dereferences a struct's data and field names unchecked, and a damaged file can leave
/// either null (found by fuzz/fuzz_skeleton_mat.cpp), so they are checked here first.
matvar_t* field_of(matvar_t* s, const char* field) {
  if (s == nullptr || s->class_type != MAT_C_STRUCT || s->data == nullptr || s->rank < 1 || s->dims == nullptr) {
    return nullptr;
  }
  std::size_t elements = 1;
  for (int i = 0; i < s->rank; ++i) elements *= s->dims[i];
  const unsigned fields = Mat_VarGetNumberOfFields(s);
  char* const* names = Mat_VarGetStructFieldnames(s);
  if (elements == 0 || fields == 0 || names == nullptr) return nullptr;
  for (unsigned i = 0; i < fields; ++i)
    if (names[i] == nullptr) return nullptr;
  if (s->nbytes / sizeof(matvar_t*) < std::size_t(fields)) return nullptr;  // fewer field slots than fields
  return Mat_VarGetStructFieldByName(s, field, 0);
}

/// A numeric MATLAB array read as doubles (column-major, as MATLAB stores it).
struct Array {
  std::vector<double> values;
  std::size_t rows = 0, cols = 0;
};

/// The array `var` (a field or variable called `what`) as doubles; throws naming it when it
/// is not a real numeric matrix of `cols` columns (0: any).
Array numeric(const matvar_t* var, const std::string& what, std::size_t cols, const std::string& name) {
  if (var == nullptr) throw InvalidInputError(name + ": " + what + " is missing");
  if (var->rank != 2 || var->isComplex || var->data == nullptr) {
    throw InvalidInputError(name + ": " + what + " must be a real numeric matrix");
  }
  Array a;
  a.rows = var->dims[0];
  a.cols = var->dims[1];
  if (cols != 0 && a.cols != cols) {
    throw InvalidInputError(name + ": " + what + " must have " + std::to_string(cols) + " column" + (cols > 1 ? "s" : "") +
                            ", it has " + std::to_string(a.cols));
  }
  const std::size_t n = a.rows * a.cols;
  std::size_t element = 0;
  switch (var->class_type) {
    case MAT_C_DOUBLE: element = 8; break;
    case MAT_C_SINGLE: element = 4; break;
    case MAT_C_INT8: case MAT_C_UINT8: element = 1; break;
    case MAT_C_INT16: case MAT_C_UINT16: element = 2; break;
    case MAT_C_INT32: case MAT_C_UINT32: element = 4; break;
    case MAT_C_INT64: case MAT_C_UINT64: element = 8; break;
    default: throw InvalidInputError(name + ": " + what + " must be numeric");
  }
  if (n != 0 && var->nbytes / n < element) throw InvalidInputError(name + ": " + what + " holds less data than its size");
  a.values.resize(n);
  const void* d = var->data;
  for (std::size_t i = 0; i < n; ++i) {
    double v = 0;
    switch (var->class_type) {
      case MAT_C_DOUBLE: v = static_cast<const double*>(d)[i]; break;
      case MAT_C_SINGLE: v = static_cast<const float*>(d)[i]; break;
      case MAT_C_INT8: v = static_cast<const std::int8_t*>(d)[i]; break;
      case MAT_C_UINT8: v = static_cast<const std::uint8_t*>(d)[i]; break;
      case MAT_C_INT16: v = static_cast<const std::int16_t*>(d)[i]; break;
      case MAT_C_UINT16: v = static_cast<const std::uint16_t*>(d)[i]; break;
      case MAT_C_INT32: v = static_cast<const std::int32_t*>(d)[i]; break;
      case MAT_C_UINT32: v = static_cast<const std::uint32_t*>(d)[i]; break;
      case MAT_C_INT64: v = static_cast<double>(static_cast<const std::int64_t*>(d)[i]); break;
      case MAT_C_UINT64: v = static_cast<double>(static_cast<const std::uint64_t*>(d)[i]); break;
      default: break;
    }
    a.values[i] = v;
  }
  return a;
}

/// The cylinders of TreeQSM's six arrays (radius, length, start, axis, parent, extension).
CylinderTable table_from(const Array& rad, const Array& len, const Array& sta, const Array& axe, const Array& par,
                         const Array* ext, const std::string& prefix, const std::string& name) {
  const std::size_t n = rad.rows;
  auto same_rows = [&](const Array& a, const char* field) {
    if (a.rows != n) {
      throw InvalidInputError(name + ": " + prefix + field + " has " + std::to_string(a.rows) + " rows, " + prefix +
                              "radius has " + std::to_string(n));
    }
  };
  same_rows(len, "length");
  same_rows(sta, "start");
  same_rows(axe, "axis");
  same_rows(par, "parent");
  if (ext != nullptr) same_rows(*ext, "extension");
  CylinderTable t;
  t.source = name;
  for (std::size_t i = 0; i < n; ++i) {
    const dvec3 start(sta.values[i], sta.values[i + n], sta.values[i + 2 * n]);
    const dvec3 axis(axe.values[i], axe.values[i + n], axe.values[i + 2 * n]);
    const double p = par.values[i];
    if (!(p >= 0 && p <= double(n) && p == std::floor(p))) {
      char value[32];
      std::snprintf(value, sizeof value, "%g", p);
      throw InvalidInputError(name + ": " + prefix + "parent(" + std::to_string(i + 1) + ") = " + value +
                              " is not a cylinder number (1 to " + std::to_string(n) + ", or 0 for the root)");
    }
    t.id.push_back(std::int64_t(i + 1));
    t.parent.push_back(std::int64_t(p));
    if (ext != nullptr) {
      const double e = ext->values[i];
      t.extension.push_back(e >= 1 && e <= double(n) ? std::int64_t(e) : 0);
    }
    t.start.push_back(start);
    t.end.push_back(start + len.values[i] * axis);
    t.radius.push_back(rad.values[i]);
    t.where.push_back("cylinder " + std::to_string(i + 1));
  }
  return t;
}

}  // namespace

RawSkeleton read_treeqsm_mat(const std::filesystem::path& path) {
  const std::string name = path.string();
  check_mat_structure(read_file(path), name);  // libmatio trusts the sizes a file declares
  // Mat_Open reads the header only; a file that is not a MAT file gives null.
  MatFile mat(Mat_Open(name.c_str(), MAT_ACC_RDONLY));
  if (!mat) {
    throw InvalidInputError(name + ": not a MATLAB MAT file (expected a TreeQSM model saved by MATLAB or Octave, v5 or v7.3)");
  }
  // The QSM: the first struct variable with a "cylinder" field; remember TreeQSM 2.3's
  // top-level arrays on the way.
  std::vector<std::pair<std::string, matio_classes>> vars;
  std::string found_vars;
  while (vars.size() < 10000) {
    MatVar info(Mat_VarReadNextInfo(mat.get()));
    if (!info) break;
    const std::string var = info->name ? info->name : "";
    if (var.empty()) continue;  // MATLAB's __function_workspace__ has no name
    vars.emplace_back(var, info->class_type);
    if (vars.size() <= 20) found_vars += (found_vars.empty() ? "" : ", ") + var;
  }
  std::string qsm_name;
  bool old_layout = false;
  for (const auto& [var, type] : vars) {
    if (var == "CPar") old_layout = true;
    if (type != MAT_C_STRUCT || !qsm_name.empty()) continue;
    MatVar whole(Mat_VarRead(mat.get(), var.c_str()));
    if (field_of(whole.get(), "cylinder") != nullptr) qsm_name = var;
  }
  if (!qsm_name.empty()) {
    MatVar qsm(Mat_VarRead(mat.get(), qsm_name.c_str()));
    if (!qsm) throw InvalidInputError(name + ": the variable " + qsm_name + " cannot be read");
    matvar_t* cyl = field_of(qsm.get(), "cylinder");
    if (cyl == nullptr || cyl->class_type != MAT_C_STRUCT) {
      throw InvalidInputError(name + ": " + qsm_name + ".cylinder must be a struct");
    }
    const std::string prefix = qsm_name + ".cylinder.";
    auto field = [&](const char* f, std::size_t cols) {
      return numeric(field_of(cyl, f), prefix + f, cols, name);
    };
    const Array rad = field("radius", 1), len = field("length", 1), sta = field("start", 3), axe = field("axis", 3),
                par = field("parent", 1);
    const matvar_t* ext_var = field_of(cyl, "extension");
    const Array ext = ext_var != nullptr ? numeric(ext_var, prefix + "extension", 1, name) : Array{};
    return cylinders_to_skeleton(table_from(rad, len, sta, axe, par, ext_var != nullptr ? &ext : nullptr, prefix, name));
  }
  if (old_layout) {
    auto var = [&](const char* v, std::size_t cols) {
      MatVar m(Mat_VarRead(mat.get(), v));
      return numeric(m.get(), v, cols, name);
    };
    const Array rad = var("Rad", 1), len = var("Len", 1), sta = var("Sta", 3), axe = var("Axe", 3), par = var("CPar", 1);
    MatVar ext_var(Mat_VarRead(mat.get(), "CExt"));
    const Array ext = ext_var ? numeric(ext_var.get(), "CExt", 1, name) : Array{};
    return cylinders_to_skeleton(table_from(rad, len, sta, axe, par, ext_var ? &ext : nullptr, "", name));
  }
  throw InvalidInputError(name + ": no TreeQSM model: no struct variable with a \"cylinder\" field (QSM, OptQSM, ...) "
                          "and no Rad/Len/Sta/Axe/CPar arrays; the file holds " +
                          (found_vars.empty() ? std::string("no variables") : found_vars));
}

}  // namespace sm
