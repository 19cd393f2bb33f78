#pragma once
/// Parameter tables: for every field of a stage's Params, its config key, the member it
/// names, the accepted range, the unit and one line of help. The Params struct holds the
/// default (its own initializer); the table is the one place everything else about a
/// parameter is written. The config reader and writer (pipeline/params.cpp, --print-config),
/// range validation (`check_params`), the viewer's panels and `strandmesh params --markdown`
/// (docs/defaults.md) all read it.
///
/// A stage declares its table next to its Params struct:
///   const ParamTable<ContourParams>& param_table(std::type_identity<ContourParams>);
/// and generic code finds it with `param_table_of<ContourParams>()`.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <variant>

#include "core/errors.h"

namespace sm {

/// Accepted values of a number: between `min` and `max`, either end open or closed; with
/// `or_zero`, 0 is accepted as well (the parameter's "off"). NaN and infinities never are.
struct ParamRange {
  double min = -std::numeric_limits<double>::infinity();
  double max = std::numeric_limits<double>::infinity();
  bool min_open = false;  ///< min itself excluded (x > min)
  bool max_open = false;  ///< max itself excluded (x < max)
  bool or_zero = false;   ///< 0 accepted besides [min, max]
  [[nodiscard]] bool contains(double x) const;
  /// The rule as validation messages and the docs print it: "> 0", ">= 0", "in [0, 180)",
  /// "0 (off) or at least 1"; "any" when every finite value is accepted.
  [[nodiscard]] std::string rule() const;
};

/// The viewer's slider for a number: its span (values outside can still be typed) and scale.
/// Left at {0, 0}, the slider spans the accepted range where that is finite.
struct ParamSlider {
  double lo = 0;
  double hi = 0;
  bool logarithmic = false;
};

/// An enum field, reached through its index: names[i] is the config spelling of value i.
template <class P>
struct ParamChoice {
  int (*get)(const P&) = nullptr;
  void (*set)(P&, int) = nullptr;
  std::span<const char* const> names;
  friend bool operator==(const ParamChoice& a, const ParamChoice& b) { return a.get == b.get && a.set == b.set; }
};

/// `param_choice<&P::field>(names)`: the ParamChoice of an enum member whose values are
/// 0 .. names.size() - 1 in the order of `names`.
template <auto Member>
auto param_choice(std::span<const char* const> names) {
  return [names]<class P, class E>(E P::*) {
    static_assert(std::is_enum_v<E>);
    return ParamChoice<P>{[](const P& p) { return static_cast<int>(p.*Member); },
                          [](P& p, int v) { p.*Member = static_cast<E>(v); }, names};
  }(Member);
}

/// A field written as text, reached through functions: a list of names, or a choice with
/// "auto" for an unset optional. `set` throws InvalidInputError for text it does not accept.
template <class P>
struct ParamText {
  std::string (*get)(const P&) = nullptr;
  void (*set)(P&, std::string_view) = nullptr;
  const char* accepted = "";  ///< what `set` accepts, as the docs print it
  friend bool operator==(const ParamText& a, const ParamText& b) { return a.get == b.get && a.set == b.set; }
};

/// One parameter. Integer members are `unsigned`, `unsigned long` or `unsigned long long`,
/// which cover std::uint32_t, std::uint64_t and std::size_t on every platform.
template <class P>
struct ParamSpec {
  using Field = std::variant<double P::*, bool P::*, unsigned P::*, unsigned long P::*, unsigned long long P::*,
                             ParamChoice<P>, ParamText<P>>;
  const char* key = "";   ///< the config key (and the member's name)
  Field field;            ///< the member
  ParamRange range = {};  ///< accepted values (numbers only)
  const char* unit = "";  ///< "m", "degrees", "count", "x local radius", ...; "" for flags and choices
  const char* help = "";  ///< one line: what it does (the unit is printed beside it)
  ParamSlider slider = {};
  /// A number that config files may also give as a name ("cm" for 100): the name's value,
  /// throwing InvalidInputError for a name it does not know (numbers only; nullptr: none).
  double (*from_name)(std::string_view) = nullptr;
};

/// A key that moved into a table's section from another section: configs written before
/// still load, `section.key` read as the table's `now` with a deprecation warning.
struct ParamMoved {
  const char* section = "";
  const char* key = "";
  const char* now = "";
};

/// A stage's table: its config section, its fields in header order, and the keys that moved
/// into it.
template <class P>
struct ParamTable {
  const char* section = "";
  std::span<const ParamSpec<P>> fields;
  std::span<const ParamMoved> moved = {};
};

/// The table of `P` (found by argument-dependent lookup next to P's declaration).
template <class P>
const ParamTable<P>& param_table_of() {
  return param_table(std::type_identity<P>{});
}

/// What kind of value a field holds (for readers, writers and widgets).
enum class ParamKind { real, integer, flag, choice, text };

template <class P>
ParamKind param_kind(const ParamSpec<P>& s) {
  switch (s.field.index()) {
    case 0:
      return ParamKind::real;
    case 1:
      return ParamKind::flag;
    case 5:
      return ParamKind::choice;
    case 6:
      return ParamKind::text;
    default:
      return ParamKind::integer;
  }
}

/// The largest value an integer field's type holds, exactly (0 for other kinds; a double
/// would round 2^64 - 1 up to 2^64, which no uint64_t holds).
template <class P>
std::uint64_t param_type_max(const ParamSpec<P>& s) {
  return std::visit(
      []<class M>(M) -> std::uint64_t {
        if constexpr (std::is_member_object_pointer_v<M>) {
          using T = std::remove_cvref_t<decltype(std::declval<P&>().*std::declval<M>())>;
          if constexpr (std::is_integral_v<T> && !std::is_same_v<T, bool>) {
            return static_cast<std::uint64_t>(std::numeric_limits<T>::max());
          }
        }
        return 0;
      },
      s.field);
}

/// A field's value as a number: flags 0/1, choices their index (text: 0).
template <class P>
double param_value(const P& p, const ParamSpec<P>& s) {
  return std::visit(
      [&p]<class M>(M m) -> double {
        if constexpr (std::is_same_v<M, ParamChoice<P>>) {
          return m.get(p);
        } else if constexpr (std::is_same_v<M, ParamText<P>>) {
          return 0.0;
        } else {
          return static_cast<double>(p.*m);
        }
      },
      s.field);
}

/// Sets a field from a number: rounded and clamped to the type for integers and choices,
/// nonzero for flags; text fields are left as they are. No range check (`check_params` does
/// that).
template <class P>
void set_param_value(P& p, const ParamSpec<P>& s, double v) {
  std::visit(
      [&p, v]<class M>(M m) {
        if constexpr (std::is_same_v<M, ParamChoice<P>>) {
          const double n = static_cast<double>(m.names.size()) - 1;
          m.set(p, static_cast<int>(std::lround(std::isnan(v) ? 0.0 : std::clamp(v, 0.0, n))));
        } else if constexpr (std::is_same_v<M, ParamText<P>>) {
          // (Set through text only.)
        } else {
          using T = std::remove_cvref_t<decltype(p.*m)>;
          if constexpr (std::is_same_v<T, bool>) {
            p.*m = v != 0.0;
          } else if constexpr (std::is_floating_point_v<T>) {
            p.*m = v;
          } else {
            const double hi = static_cast<double>(std::numeric_limits<T>::max());
            if (std::isnan(v) || v <= 0) {
              p.*m = 0;
            } else if (v >= hi) {
              p.*m = std::numeric_limits<T>::max();
            } else {
              p.*m = static_cast<T>(std::round(v));  // (llround overflows above 2^63)
            }
          }
        }
      },
      s.field);
}

/// Throws InvalidInputError "SECTION.KEY must be RULE, got VALUE" for the first number
/// outside its range (flags, choices and text are checked as they are set).
template <class P>
void check_params(const P& p) {
  const ParamTable<P>& t = param_table_of<P>();
  const ParamChecker check{t.section};
  for (const ParamSpec<P>& s : t.fields) {
    const ParamKind kind = param_kind(s);
    if (kind == ParamKind::flag || kind == ParamKind::choice || kind == ParamKind::text) continue;
    const double x = param_value(p, s);
    check.require(s.range.contains(x), s.key, s.range.rule().c_str(), x);
  }
}

}  // namespace sm
