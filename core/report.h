#pragma once
/// Counted warnings and stage timings: what a stage returns besides its result.
///
/// Libraries never print. A stage records each repair or degenerate case it met as a counted
/// warning (a kind, how often, the first few places) and its phase timings; the apps decide
/// what to show. Repeated warnings are batched by kind, as polyscope does.

#include <chrono>
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace sm {

/// One kind of warning with its count and up to `Warnings::max_examples` example places.
struct Warning {
  std::string kind;                   ///< short stable key, e.g. "zero_radius_raised"
  std::string message;                ///< one sentence describing the rule and the repair
  std::size_t count = 0;              ///< how many times it happened
  std::vector<std::string> examples;  ///< the first places (Warnings::max_kept_examples), e.g. "node id 17"
};

/// An ordered list of counted warnings (order of first occurrence, hence deterministic as long
/// as the caller records them in a deterministic order).
class Warnings {
 public:
  static constexpr std::size_t max_examples = 3;         ///< examples shown by to_string()
  static constexpr std::size_t max_kept_examples = 1000;  ///< examples kept (the CLI lists them with -v)

  /// Counts one occurrence of `kind`; `message` is kept from the first call, `where` is kept
  /// as an example while fewer than max_examples are stored.
  void add(std::string_view kind, std::string_view message, std::string_view where = {});
  /// Adds `n` occurrences at once (no example).
  void add_count(std::string_view kind, std::string_view message, std::size_t n);
  /// Appends all warnings of `other` (merging equal kinds).
  void merge(const Warnings& other);

  [[nodiscard]] const std::vector<Warning>& list() const { return list_; }
  [[nodiscard]] std::size_t count(std::string_view kind) const;
  [[nodiscard]] std::size_t total() const;
  [[nodiscard]] bool empty() const { return list_.empty(); }
  /// One line per kind: "message (N×; e.g. node id 3, node id 9)".
  [[nodiscard]] std::string to_string() const;

 private:
  Warning& find_or_add(std::string_view kind, std::string_view message);
  std::vector<Warning> list_;
};

/// Named wall-clock timings of a stage's phases, in seconds.
struct Timings {
  struct Entry {
    std::string name;
    double seconds = 0;
  };
  std::vector<Entry> entries;

  void add(std::string_view name, double seconds);
  [[nodiscard]] double get(std::string_view name) const;  ///< 0 when absent
  [[nodiscard]] double total() const;
};

/// A monotonic stopwatch. `lap()` returns seconds since the last lap (or construction).
class Stopwatch {
 public:
  Stopwatch() : start_(Clock::now()), last_(start_) {}
  double lap() {
    const auto now = Clock::now();
    const double s = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    return s;
  }
  [[nodiscard]] double elapsed() const { return std::chrono::duration<double>(Clock::now() - start_).count(); }

 private:
  using Clock = std::chrono::steady_clock;
  Clock::time_point start_, last_;
};

}  // namespace sm
