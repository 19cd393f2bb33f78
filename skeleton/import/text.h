#pragma once
/// Small text helpers shared by the table and MTG readers (internal to skeleton/import).

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "core/input_limits.h"

namespace sm::import {

/// `s` without leading and trailing blanks (space, tab, CR).
inline std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t' || s.front() == '\r')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

/// A decimal number ("1.5", "-2e-3", "nan" and "inf" too: validation names those later).
inline bool parse_number(std::string_view tok, double& out) {
  if (tok.empty() || tok.size() > 64) return false;
  char buf[65];
  tok.copy(buf, tok.size());
  buf[tok.size()] = '\0';
  char* end = nullptr;
  out = std::strtod(buf, &end);
  return end == buf + tok.size();
}

/// An integer, also written as a float with a zero fraction ("12.0", as R and MATLAB print).
inline bool parse_integer(std::string_view tok, std::int64_t& out) {
  auto [p, ec] = std::from_chars(tok.data(), tok.data() + tok.size(), out);
  if (ec == std::errc() && p == tok.data() + tok.size()) return true;
  double d = 0;
  if (parse_number(tok, d) && std::isfinite(d) && d == std::floor(d) && std::abs(d) < 9e15) {
    out = static_cast<std::int64_t>(d);
    return true;
  }
  return false;
}

/// A column or feature name reduced for matching: lower case, letters and digits only
/// ("start_X", "startX" and "start.x" all become "startx").
inline std::string normalize_name(std::string_view name) {
  std::string out;
  for (const char ch : name) {
    if (std::isalnum(static_cast<unsigned char>(ch))) out += static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  }
  return out;
}

/// `s` quoted for a message, cut to a short excerpt (core/input_limits.h).
inline std::string quoted(std::string_view s) {
  std::string out(1, '"');  // appended, not "\"" + ...: GCC 12 warns falsely (-Wrestrict) on that
  out += excerpt(s, 40);
  out += '"';
  return out;
}

/// Calls f(line, line_number) for each line of `text` (1-based; '\n' ends a line, a '\r'
/// before it is dropped). Stops early when f returns false.
template <class F>
void for_each_line(std::string_view text, F&& f) {
  std::size_t start = 0, number = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(start, end - start);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (!f(line, ++number)) return;
    start = end + 1;
  }
}

}  // namespace sm::import
