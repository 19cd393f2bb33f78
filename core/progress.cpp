#include "core/progress.h"

#include <algorithm>
#include <cmath>

namespace sm {

OverallProgress::OverallProgress(std::vector<Phase> phases) : phases_(std::move(phases)) {
  for (const Phase& p : phases_) total_ += p.weight;
}

OverallProgress OverallProgress::pipeline() {
  // Shares of a run on the grow presets (bench --preset large and the samples), roughly.
  return OverallProgress({{"skeleton", 2},
                          {"particles", 25},
                          {"strands", 5},
                          {"contours", 25},
                          {"meshing", 20},
                          {"fork retry", 5},
                          {"outer surface", 3},
                          {"repair", 5},
                          {"export", 10}});
}

double OverallProgress::update(std::string_view phase, double fraction) {
  if (!(fraction >= 0)) fraction = 0;  // NaN too
  fraction = std::min(fraction, 1.0);
  double before = 0;
  for (const Phase& p : phases_) {
    if (p.name == phase) {
      if (total_ > 0) done_ = std::max(done_, std::min(1.0, (before + p.weight * fraction) / total_));
      return done_;
    }
    before += p.weight;
  }
  return done_;  // an unknown phase: hold
}

}  // namespace sm
