#include "apps/cli/cli.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <unistd.h>

#include "core/errors.h"
#include "core/file_io.h"
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

ProgressBar::ProgressBar(bool enabled, std::optional<OverallProgress> overall)
    : enabled_(enabled && ::isatty(2)), overall_(std::move(overall)) {}
ProgressBar::~ProgressBar() { finish(); }

std::string ProgressBar::line(std::string_view phase, double fraction, double seconds) {
  const int percent = static_cast<int>(std::floor(fraction * 100.0));
  constexpr int kWidth = 30;
  std::string bar(static_cast<std::size_t>(percent * kWidth / 100), '#');
  bar.resize(kWidth, '.');
  char text[160];
  std::snprintf(text, sizeof text, "%-13.*s [%s] %3d%%", static_cast<int>(std::min<std::size_t>(phase.size(), 60)),
                phase.data(), bar.c_str(), percent);
  std::string out = text;
  // The time left, once the run has shown its pace (a few seconds and a few percent).
  if (seconds >= 3 && fraction >= 0.03 && fraction < 1) {
    const double left = seconds * (1 - fraction) / fraction;
    if (left >= 60) {
      std::snprintf(text, sizeof text, "  ETA %d min %02d s", static_cast<int>(left / 60), static_cast<int>(left) % 60);
    } else {
      std::snprintf(text, sizeof text, "  ETA %d s", static_cast<int>(std::ceil(left)));
    }
    out += text;
  }
  return out;
}

void ProgressBar::update(std::string_view phase, double fraction) {
  if (!enabled_) return;
  if (overall_) {
    shown_ = overall_->update(phase, fraction);
  } else {
    if (phase != phase_) shown_ = 0;
    if (fraction >= shown_) shown_ = std::min(fraction, 1.0);
  }
  const int permille = static_cast<int>(shown_ * 1000);
  const int second = static_cast<int>(clock_.elapsed());
  if (permille == last_permille_ && phase == phase_ && second == last_second_) return;
  last_permille_ = permille;
  last_second_ = second;
  phase_ = std::string(phase);
  const std::string text = line(phase_, shown_, clock_.elapsed());
  const std::size_t pad = width_ > text.size() ? width_ - text.size() : 0;
  width_ = std::max(width_, text.size());
  std::fprintf(stderr, "\r%s%*s", text.c_str(), static_cast<int>(pad), "");
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::finish() {
  if (drawn_) {
    std::fprintf(stderr, "\r%*s\r", static_cast<int>(width_), "");
    std::fflush(stderr);
    drawn_ = false;
  }
}

void write_output(const std::string& path, std::string_view bytes) {
  if (path != "-") {
    write_file_atomically(path, bytes);
    return;
  }
  std::fwrite(bytes.data(), 1, bytes.size(), stdout);
  if (std::fflush(stdout) != 0) throw IoError("cannot write to standard output");
}

const std::set<std::string> kExpectedOfGrownTrees{"thin_tip"};

void print_warnings(const Warnings& warnings, bool verbose, const std::set<std::string>& expected) {
  for (const auto& w : warnings.list()) {
    std::string line = w.message + " (" + std::to_string(w.count) + "x";
    const std::size_t shown = verbose ? 0 : std::min(w.examples.size(), Warnings::max_examples);
    for (std::size_t i = 0; i < shown; ++i) line += (i == 0 ? "; e.g. " : ", ") + w.examples[i];
    if (!verbose && w.count > shown && shown > 0) line += "; -v lists them";
    line += ")";
    if (expected.count(w.kind)) {
      log::verbose("as grown on purpose: " + line);
    } else {
      log::warn(line);
    }
    if (verbose) {
      for (const auto& e : w.examples) log::verbose("    " + e);
      if (w.count > w.examples.size() && !w.examples.empty()) {
        log::verbose("    ... and " + std::to_string(w.count - w.examples.size()) + " more");
      }
    }
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
