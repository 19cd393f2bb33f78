#pragma once
/// The one log sink of the apps. Stage libraries do not log; they return Stats/Warnings.

#include <string_view>

namespace sm::log {

enum class Level { quiet = 0, normal = 1, verbose = 2 };

void set_level(Level level);
Level level();

/// Progress and results (suppressed by --quiet), on stderr.
void info(std::string_view message);
/// Details (only with --verbose), on stderr.
void verbose(std::string_view message);
/// Warnings (suppressed by --quiet), on stderr, prefixed "warning: ".
void warn(std::string_view message);
/// Errors (always), on stderr, prefixed "error: ".
void error(std::string_view message);

}  // namespace sm::log
