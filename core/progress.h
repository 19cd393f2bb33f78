#pragma once
/// Progress reporting for long runs: stages accept an optional callback, the apps draw it.

#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace sm {

/// Called with the phase name and the fraction done in [0, 1]. May be called from worker
/// threads but never concurrently (stages serialize the calls). An empty function is allowed.
using ProgressFn = std::function<void(std::string_view phase, double fraction)>;

/// Turns the stages' (phase, fraction) reports into one fraction of the whole run that only
/// moves forward: each known phase owns a share of the run (its weight), phases re-run later
/// (a retry) or unknown ones hold the fraction where it is until a later phase passes it.
class OverallProgress {
 public:
  struct Phase {
    std::string name;  ///< as the stage reports it ("particles")
    double weight;     ///< share of the run's time, any positive unit
  };
  explicit OverallProgress(std::vector<Phase> phases);
  /// The pipeline's phases and the export, weighted by their typical share of a run.
  static OverallProgress pipeline();
  /// Records a report; returns the run's fraction in [0, 1], never below an earlier one.
  double update(std::string_view phase, double fraction);
  [[nodiscard]] double fraction() const { return done_; }

 private:
  std::vector<Phase> phases_;
  double total_ = 0;
  double done_ = 0;
};

}  // namespace sm
