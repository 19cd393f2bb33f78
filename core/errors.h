#pragma once
/// The exceptions thrown at stage boundaries.
///
/// Every message names the place (file and line, node id, parameter) and the rule that was
/// broken, so that the CLI can print it as is. The CLI maps them to exit codes:
/// `InvalidInputError` and `IoError` → 1, `UsageError` → 2, anything else → 3.

#include <stdexcept>
#include <string>

namespace sm {

/// Base class of all strandmesh errors.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The input (skeleton file, parameters, config) breaks a rule; the user must fix it.
class InvalidInputError : public Error {
 public:
  using Error::Error;
};

/// A file cannot be read or written.
class IoError : public Error {
 public:
  using Error::Error;
};

/// The command line or a config file asks for something that does not exist.
class UsageError : public Error {
 public:
  using Error::Error;
};

/// An internal invariant failed: a bug in strandmesh, never the user's fault.
class InternalError : public Error {
 public:
  using Error::Error;
};

/// Throws InternalError with `what` and the source location when `cond` is false.
/// Used for invariants that must hold in release builds as well (cheap checks only).
void check_invariant(bool cond, const char* what, const char* file, int line);

/// Range checks of a stage's parameters: each throws InvalidInputError "SECTION.KEY must be
/// RULE, got VALUE" (e.g. "contours.slice_step must be > 0, got 0") when the value is out of
/// range; NaN and infinities are always out.
struct ParamChecker {
  const char* section;  ///< the config section: "skeleton", "contours", ...
  void require(bool ok, const char* key, const char* rule, double got) const;
  void positive(double x, const char* key) const;                      ///< finite and > 0
  void non_negative(double x, const char* key) const;                  ///< finite and >= 0
  void within(double x, double lo, double hi, const char* key) const;  ///< finite and in [lo, hi]
};

}  // namespace sm

#define SM_CHECK(cond, what) ::sm::check_invariant(static_cast<bool>(cond), what, __FILE__, __LINE__)
