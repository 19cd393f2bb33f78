#pragma once
/// Progress reporting for long runs: stages accept an optional callback, the apps draw it.

#include <functional>
#include <string_view>

namespace sm {

/// Called with the phase name and the fraction done in [0, 1]. May be called from worker
/// threads but never concurrently (stages serialize the calls). An empty function is allowed.
using ProgressFn = std::function<void(std::string_view phase, double fraction)>;

}  // namespace sm
