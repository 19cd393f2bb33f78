#pragma once
/// The shape of every strandmesh fuzz target (libFuzzer): one reader, fed the fuzzer's bytes.
///
/// A rejection of malformed input (InvalidInputError, IoError, UsageError) is the expected
/// outcome and is ignored; anything else is a finding and aborts so libFuzzer keeps the
/// input: an InternalError (exit 3 in the CLI) or any other exception, a crash, a sanitizer
/// report, a hang (libFuzzer's -timeout) or unbounded memory (-rss_limit_mb).
/// A rejection must also name its place: a message without ':' (no file, line or node) is
/// a finding too.
///
/// A new reader gets a target in a few lines (fuzz_skeleton_json.cpp is the model):
///   #include "fuzz/fuzz_reader.h"
///   SM_FUZZ_READER(text) { sm::build_skeleton(sm::parse_my_format(text, "fuzz.myf")); }
/// plus `strandmesh_fuzzer(fuzz_my_format SOURCES fuzz_my_format.cpp LIBS sm::skeleton
/// CORPUS <folder of seeds>)` in fuzz/CMakeLists.txt; scripts/fuzz.sh and CI run every target.

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>
#include <string_view>

#include "core/errors.h"

namespace sm::fuzz {

/// Calls `body(text)`; returns normally on a rejection that names its place, aborts otherwise.
template <class Body>
int run_reader(const std::uint8_t* data, std::size_t size, Body&& body) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    body(text);
  } catch (const InternalError& e) {
    std::fprintf(stderr, "fuzz finding: internal error: %s\n", e.what());
    std::abort();
  } catch (const InvalidInputError& e) {
    if (std::string_view(e.what()).find(':') == std::string_view::npos) {
      std::fprintf(stderr, "fuzz finding: a rejection that names no place: %s\n", e.what());
      std::abort();
    }
  } catch (const IoError&) {
  } catch (const UsageError&) {
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz finding: unexpected exception: %s\n", e.what());
    std::abort();
  }
  return 0;
}

}  // namespace sm::fuzz

/// Defines the libFuzzer entry point; the block that follows gets `std::string_view VAR`.
#define SM_FUZZ_READER(VAR)                                                              \
  static void sm_fuzz_body(std::string_view VAR);                                        \
  extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {    \
    return ::sm::fuzz::run_reader(data, size, [](std::string_view t) { sm_fuzz_body(t); }); \
  }                                                                                      \
  static void sm_fuzz_body(std::string_view VAR)
