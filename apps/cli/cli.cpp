#include "apps/cli/cli.h"

#include <cstdio>
#include <unistd.h>

#include "core/log.h"

namespace sm::cli {

namespace {
std::vector<std::pair<CLI::App*, Action>>& registry() {
  static std::vector<std::pair<CLI::App*, Action>> r;
  return r;
}
}  // namespace

void add_command(CLI::App& app, const std::string& name, const std::string& description,
                 const std::function<Action(CLI::App& sub)>& setup) {
  CLI::App* sub = app.add_subcommand(name, description);
  registry().emplace_back(sub, setup(*sub));
}

Action parsed_action() {
  for (auto& [sub, action] : registry()) {
    if (sub->parsed()) return action;
  }
  return {};
}

void add_unavailable_command(CLI::App& app, const std::string& name, const std::string& description) {
  add_command(app, name, description + " (not yet available)", [name](CLI::App& sub) -> Action {
    sub.allow_extras();
    return [name] {
      std::fprintf(stderr, "error: 'strandmesh %s' is not yet available in this version\n", name.c_str());
      return int(kUsage);
    };
  });
}

ProgressBar::ProgressBar(bool enabled) : enabled_(enabled && ::isatty(2)) {}
ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(std::string_view phase, double fraction) {
  if (!enabled_) return;
  const int percent = static_cast<int>(fraction * 100.0 + 0.5);
  if (percent == last_percent_ && phase == phase_) return;
  last_percent_ = percent;
  phase_ = std::string(phase);
  const int width = 30;
  const int filled = percent * width / 100;
  std::string bar(static_cast<std::size_t>(filled), '#');
  bar.resize(width, '.');
  std::fprintf(stderr, "\r%-12.12s [%s] %3d%%", phase_.c_str(), bar.c_str(), percent);
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::finish() {
  if (drawn_) {
    std::fprintf(stderr, "\r%*s\r", 60, "");
    std::fflush(stderr);
    drawn_ = false;
  }
}

void verbose_phases(const Timings& phases) {
  char line[128];
  for (const auto& e : phases.entries) {
    std::snprintf(line, sizeof line, "    %-12s %8.3f s", e.name.c_str(), e.seconds);
    log::verbose(line);
  }
}

}  // namespace sm::cli
