#include "core/input_limits.h"

#include <algorithm>

#include <nlohmann/json.hpp>

#include "core/errors.h"

namespace sm {

void check_json_nesting(std::string_view text, const std::string& name, int max_depth) {
  int depth = 0;
  bool in_string = false;
  std::size_t line = 1, line_start = 0;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') {
        ++i;  // the escaped character cannot end the string
      } else if (c == '"') {
        in_string = false;
      } else if (c == '\n') {  // invalid in JSON; the parser will say so, keep counting lines
        ++line;
        line_start = i + 1;
      }
      continue;
    }
    switch (c) {
      case '"':
        in_string = true;
        break;
      case '[':
      case '{':
        if (++depth > max_depth) {
          throw InvalidInputError(name + ":" + std::to_string(line) + ":" + std::to_string(i - line_start + 1) +
                                  ": JSON nested deeper than " + std::to_string(max_depth) +
                                  " levels (arrays and objects)");
        }
        break;
      case ']':
      case '}':
        if (depth > 0) --depth;
        break;
      case '\n':
        ++line;
        line_start = i + 1;
        break;
      default:
        break;
    }
  }
}

namespace {

/// Accepts every value and remembers where the parser gave up.
struct StopFinder final : nlohmann::json_sax<nlohmann::json> {
  using json = nlohmann::json;
  std::size_t stop = std::string::npos;
  std::size_t token_size = 0;
  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(json::number_integer_t) override { return true; }
  bool number_unsigned(json::number_unsigned_t) override { return true; }
  bool number_float(json::number_float_t, const json::string_t&) override { return true; }
  bool string(json::string_t&) override { return true; }
  bool binary(json::binary_t&) override { return true; }
  bool start_object(std::size_t) override { return true; }
  bool key(json::string_t&) override { return true; }
  bool end_object() override { return true; }
  bool start_array(std::size_t) override { return true; }
  bool end_array() override { return true; }
  bool parse_error(std::size_t position, const std::string& last_token, const json::exception&) override {
    stop = position;  // bytes read, the offending token included
    token_size = last_token.size();
    return false;
  }
};

}  // namespace

std::string json_error_line_col(std::string_view text) {
  StopFinder finder;
  nlohmann::json::sax_parse(text.begin(), text.end(), &finder);
  if (finder.stop == std::string::npos) return "";
  const std::size_t start = std::min(text.size(), finder.stop >= finder.token_size ? finder.stop - finder.token_size : 0);
  std::size_t line = 1, line_start = 0;
  for (std::size_t i = 0; i < start; ++i) {
    if (text[i] == '\n') {
      ++line;
      line_start = i + 1;
    }
  }
  return std::to_string(line) + ":" + std::to_string(start - line_start + 1);
}

std::string excerpt(std::string_view value, std::size_t max_chars) {
  std::string out(value.substr(0, max_chars));
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  }
  if (value.size() > max_chars) out += "... (" + std::to_string(value.size()) + " characters)";
  return out;
}

}  // namespace sm
