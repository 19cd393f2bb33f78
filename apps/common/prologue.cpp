#include "apps/common/prologue.h"

#include <exception>
#include <new>
#include <string>

#include "apps/common/huge_pages.h"
#include "core/errors.h"
#include "core/log.h"

namespace sm::app {

void start_process(char** argv) {
  reexec_with_huge_pages(argv);
  keep_freed_memory();
}

std::optional<int> parse_command_line(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    app.exit(e);
    return kUsage;
  }
  return std::nullopt;
}

std::unique_ptr<tbb::global_control> apply_common_options(int threads, bool quiet, bool verbose) {
  log::set_level(quiet ? log::Level::quiet : verbose ? log::Level::verbose : log::Level::normal);
  if (running_with_huge_pages()) log::verbose("memory: transparent huge pages (glibc.malloc.hugetlb=1)");
  if (threads <= 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                               static_cast<std::size_t>(threads));
}

int run_reporting_errors(const std::function<int()>& body) {
  try {
    return body();
  } catch (const InvalidInputError& e) {
    log::error(e.what());
    return kBadInput;
  } catch (const IoError& e) {
    log::error(e.what());
    return kBadInput;
  } catch (const UsageError& e) {
    log::error(e.what());
    return kUsage;
  } catch (const std::bad_alloc&) {
    log::error("out of memory");
    return kInternal;
  } catch (const std::exception& e) {
    log::error(std::string("internal error: ") + e.what());
    return kInternal;
  }
}

}  // namespace sm::app
