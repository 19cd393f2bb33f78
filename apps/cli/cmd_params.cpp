// strandmesh params: every config key with its default, accepted values, unit and meaning.

#include <cstdio>

#include "apps/cli/commands.h"

namespace sm::cli {

void add_params_command(CLI::App& app, const GlobalOptions&) {
  add_command(app, "params", "List every parameter: config key, default, accepted values, unit, meaning",
              [](CLI::App& sub) -> Action {
                auto markdown = std::make_shared<bool>(false);
                sub.add_flag("--markdown", *markdown, "As Markdown tables (the reference in docs/defaults.md)");
                return [markdown] {
                  std::fputs(params_reference(*markdown).c_str(), stdout);
                  return int(kOk);
                };
              });
}

}  // namespace sm::cli
