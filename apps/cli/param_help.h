#pragma once
// A flag's help is its config key's row in the stage's parameter table (core/param_table.h),
// so a flag and the config file it stands for cannot drift apart.

#include <cctype>
#include <string>
#include <string_view>
#include <variant>

#include "core/errors.h"
#include "core/param_table.h"

namespace sm::cli {

/// The row of `key` in P's table (an InternalError if there is none: a flag naming no key).
template <class P>
const ParamSpec<P>& param_spec(std::string_view key) {
  for (const ParamSpec<P>& s : param_table_of<P>().fields) {
    if (key == s.key) return s;
  }
  throw InternalError("no parameter " + std::string(param_table_of<P>().section) + "." + std::string(key));
}

/// "Help: accepted values (unit)`more` [config: section.key; range]".
template <class P>
std::string param_help(std::string_view key, std::string_view more = {}) {
  const ParamSpec<P>& s = param_spec<P>(key);
  std::string h = s.help;
  if (!h.empty()) h[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(h[0])));
  if (const auto* text = std::get_if<ParamText<P>>(&s.field)) h += std::string(": ") + text->accepted;
  if (const auto* choice = std::get_if<ParamChoice<P>>(&s.field)) {
    for (std::size_t k = 0; k < choice->names.size(); ++k) h += std::string(k ? ", " : ": ") + choice->names[k];
  }
  if (*s.unit) h += std::string(" (") + s.unit + ")";
  h += more;
  const ParamKind kind = param_kind(s);
  const bool ranged = kind != ParamKind::choice && kind != ParamKind::text && kind != ParamKind::flag;
  return h + " [config: " + param_table_of<P>().section + "." + s.key + (ranged ? "; " + s.range.rule() : "") + "]";
}

}  // namespace sm::cli
