#pragma once
/// One background job at a time, off the render thread: loading, re-running stages, mesh
/// checks. The window keeps drawing while it runs; the job reports progress through atomics
/// and a mutex-guarded phase name, and hands its result back when the render thread asks.
///
/// Cancelling: the stages take a progress callback; the job's callback throws `Cancelled`
/// once cancel() was called, so a run stops at the next progress report of its stage.

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "core/progress.h"
#include "core/report.h"
#include "viewer/run.h"

namespace sm::viewer {

/// Thrown by a job's progress callback after cancel().
struct Cancelled {};

/// What a job hands back. Exactly one of run, check or error is set.
struct JobOutcome {
  enum class Kind { load, rerun, checks } kind = Kind::load;
  std::shared_ptr<const RunData> run;    ///< load and rerun: the new run
  std::optional<MeshCheckReport> check;  ///< checks: the report
  std::string error;                     ///< the exception's message when the job failed
  bool cancelled = false;                ///< the job was cancelled (error says so too)
  double seconds = 0;                    ///< wall-clock time of the job
};

/// Progress of the running job.
struct JobProgress {
  bool running = false;
  std::string phase;    ///< stage or phase name, as reported by the stage
  double fraction = 0;  ///< of that phase, [0, 1]
  double seconds = 0;   ///< since the job started
  JobOutcome::Kind kind = JobOutcome::Kind::load;
};

class Job {
 public:
  /// The work: builds an outcome (its kind is filled in), calling `progress` as it goes.
  /// Exceptions are caught: sm::Error and std::exception become `error`.
  using Work = std::function<JobOutcome(const ProgressFn& progress)>;

  Job() = default;
  ~Job();  ///< cancels and joins
  Job(const Job&) = delete;
  Job& operator=(const Job&) = delete;

  /// Starts `work` on a new thread. Precondition: !busy() (a finished outcome not yet taken
  /// is dropped).
  void start(JobOutcome::Kind kind, Work work);
  /// True from start() until the outcome has been taken.
  [[nodiscard]] bool busy() const;
  /// True while the work runs (false once it finished, even if not yet taken).
  [[nodiscard]] bool running() const { return running_.load(); }
  /// The outcome once the work finished (joins the thread); std::nullopt while it runs or
  /// when idle.
  std::optional<JobOutcome> take();
  /// Blocks until the work finished (then take() returns its outcome).
  void wait();
  /// Asks the work to stop at its next progress report.
  void cancel() { cancel_.store(true); }
  [[nodiscard]] JobProgress progress() const;

 private:
  std::thread thread_;
  std::atomic<bool> running_{false};
  std::atomic<bool> cancel_{false};
  std::atomic<double> fraction_{0.0};
  mutable std::mutex mutex_;  // guards phase_, outcome_
  std::string phase_;
  std::optional<JobOutcome> outcome_;
  JobOutcome::Kind kind_ = JobOutcome::Kind::load;
  Stopwatch clock_;
};

}  // namespace sm::viewer
