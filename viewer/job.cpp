// The background job: a std::thread per job (jobs are seconds long and rare, so a pool would
// buy nothing), with progress in atomics so the render thread never waits on the stages.

#include "viewer/job.h"

#include "core/errors.h"

namespace sm::viewer {

Job::~Job() {
  cancel();
  if (thread_.joinable()) thread_.join();
}

void Job::start(JobOutcome::Kind kind, Work work) {
  if (thread_.joinable()) thread_.join();
  {
    std::lock_guard lock(mutex_);
    outcome_.reset();
    phase_ = "starting";
  }
  cancel_.store(false);
  fraction_.store(0.0);
  kind_ = kind;
  clock_ = Stopwatch();
  running_.store(true);
  thread_ = std::thread([this, kind, work = std::move(work)] {
    Stopwatch clock;
    JobOutcome out;
    const ProgressFn progress = [this](std::string_view phase, double fraction) {
      if (cancel_.load()) throw Cancelled{};
      {
        std::lock_guard lock(mutex_);
        if (phase_ != phase) phase_.assign(phase);
      }
      fraction_.store(fraction);
    };
    try {
      out = work(progress);
    } catch (const Cancelled&) {
      out = JobOutcome{};
      out.cancelled = true;
      out.error = "cancelled";
    } catch (const Error& e) {
      out = JobOutcome{};
      out.error = e.what();
    } catch (const std::exception& e) {
      out = JobOutcome{};
      out.error = std::string("unexpected error: ") + e.what();
    } catch (...) {
      out = JobOutcome{};
      out.error = "unexpected error";
    }
    out.kind = kind;
    out.seconds = clock.elapsed();
    {
      std::lock_guard lock(mutex_);
      outcome_ = std::move(out);
    }
    running_.store(false);
  });
}

bool Job::busy() const {
  if (running_.load()) return true;
  std::lock_guard lock(mutex_);
  return outcome_.has_value();
}

std::optional<JobOutcome> Job::take() {
  if (running_.load()) return std::nullopt;
  if (thread_.joinable()) thread_.join();
  std::lock_guard lock(mutex_);
  std::optional<JobOutcome> out = std::move(outcome_);
  outcome_.reset();
  return out;
}

void Job::wait() {
  if (thread_.joinable()) thread_.join();
}

JobProgress Job::progress() const {
  JobProgress p;
  p.running = running_.load();
  p.fraction = fraction_.load();
  p.seconds = clock_.elapsed();
  p.kind = kind_;
  std::lock_guard lock(mutex_);
  p.phase = phase_;
  return p;
}

}  // namespace sm::viewer
