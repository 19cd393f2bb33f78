#include "core/log.h"

#include <atomic>
#include <cstdio>
#include <mutex>
#include <string>

namespace sm::log {
namespace {
std::atomic<Level> g_level{Level::normal};
std::mutex g_mutex;

void emit(std::string_view prefix, std::string_view message) {
  std::lock_guard lock(g_mutex);
  std::string line(prefix);
  line += message;
  if (line.empty() || line.back() != '\n') line += '\n';
  std::fwrite(line.data(), 1, line.size(), stderr);
}
}  // namespace

void set_level(Level l) { g_level = l; }
Level level() { return g_level; }
void info(std::string_view m) {
  if (g_level >= Level::normal) emit("", m);
}
void verbose(std::string_view m) {
  if (g_level >= Level::verbose) emit("", m);
}
void warn(std::string_view m) {
  if (g_level >= Level::normal) emit("warning: ", m);
}
void error(std::string_view m) { emit("error: ", m); }

}  // namespace sm::log
