#include "core/input_limits.h"

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

std::string excerpt(std::string_view value, std::size_t max_chars) {
  std::string out(value.substr(0, max_chars));
  for (char& c : out) {
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
  }
  if (value.size() > max_chars) out += "... (" + std::to_string(value.size()) + " characters)";
  return out;
}

}  // namespace sm
