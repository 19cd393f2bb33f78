#include "apps/common/prologue.h"

#include <algorithm>
#include <cstdio>
#include <exception>
#include <new>
#include <string>

#include "apps/common/huge_pages.h"
#include "core/errors.h"
#include "core/log.h"
#include "core/suggest.h"

namespace sm::app {

void start_process(char** argv) {
  reexec_with_huge_pages(argv);
  keep_freed_memory();
}

namespace {

// "Did you mean": the closest subcommand to an unknown command word, or the closest long
// option (of the command given, or the program) to an unknown --option. Empty when nothing is
// close enough (core/suggest.h).
std::string suggestion(CLI::App& app, int argc, char** argv) {
  std::vector<std::string> commands;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) commands.push_back(sub->get_name());
  auto long_names = [](const CLI::App& a, std::vector<std::string>& out) {
    for (const CLI::Option* o : a.get_options()) {
      for (const std::string& n : o->get_lnames()) out.push_back("--" + n);
    }
  };
  CLI::App* command = nullptr;
  for (int i = 1; i < argc && !commands.empty(); ++i) {
    const std::string word = argv[i];
    if (word == "--threads") {
      ++i;  // its value
      continue;
    }
    if (!word.empty() && word[0] == '-') continue;
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
      if (sub->get_name() == word) command = sub;
    }
    if (command == nullptr) {
      const std::string best = closest_name(word, commands);
      return best.empty() ? "" : "unknown command '" + word + "': did you mean 'strandmesh " + best + "'?";
    }
    break;
  }
  std::vector<std::string> options;
  long_names(app, options);
  if (command != nullptr) long_names(*command, options);
  for (int i = 1; i < argc; ++i) {
    std::string word = argv[i];
    if (word.rfind("--", 0) != 0 || word == "--") continue;
    word = word.substr(0, word.find('='));
    if (std::find(options.begin(), options.end(), word) != options.end()) continue;
    const std::string best = closest_name(word, options);
    if (!best.empty()) return "unknown option '" + word + "': did you mean '" + best + "'?";
  }
  return {};
}

}  // namespace

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
    if (const std::string hint = suggestion(app, argc, argv); !hint.empty()) {
      std::fprintf(stderr, "error: %s\nRun with --help for more information.\n", hint.c_str());
      return kUsage;
    }
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
