#pragma once
/// Limits every reader applies before parsing, so that no input can drive the tool into deep
/// recursion, unbounded reads or megabyte-long error messages.
///
///  - JSON of any kind (skeletons, configs, presets, stage dumps, glTF) is scanned for its
///    nesting depth before a parser sees it: nlohmann's dump and tinygltf's value conversion
///    recurse once per level, so a value nested 100,000 deep overflowed the stack.
///  - Values echoed in error messages are cut to a short excerpt (a rejected value of 200 KB
///    was printed whole).
/// The size limit of input files is in core/file_io.h (read_file).

#include <cstddef>
#include <string>
#include <string_view>

namespace sm {

/// Deepest nesting of arrays and objects accepted in a JSON input (a skeleton needs 3, a
/// glTF file about 8; extras beyond this are refused).
inline constexpr int kMaxJsonDepth = 100;

/// Throws InvalidInputError "NAME:LINE:COL: JSON nested deeper than N levels (arrays and
/// objects)" when `text` nests arrays and objects deeper than `max_depth`; strings (with
/// escapes) are skipped. Linear, no recursion; says nothing about whether `text` is valid JSON.
void check_json_nesting(std::string_view text, const std::string& name, int max_depth = kMaxJsonDepth);

/// "LINE:COL" (1-based) of the token where nlohmann's parser stops on `text`, or "" when it
/// parses. For the errors whose exception carries no position: a number beyond double's range
/// (out_of_range.406, "number overflow parsing '1e999'"). A second, iterative (SAX) pass: call
/// it on the error path only, after check_json_nesting.
std::string json_error_line_col(std::string_view text);

/// `value` as it can be echoed in a message: unchanged when at most `max_chars` long, else
/// its first `max_chars` characters, "..." and its full length ("[[[[... (200000 characters)").
/// Control characters are shown as '?'.
std::string excerpt(std::string_view value, std::size_t max_chars = 60);

}  // namespace sm
