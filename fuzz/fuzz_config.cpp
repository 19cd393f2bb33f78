// Fuzz target: pipeline config files (pipeline/pipeline.h, parse_params_json).
#include "fuzz/fuzz_reader.h"
#include "pipeline/pipeline.h"

SM_FUZZ_READER(text) {
  (void)sm::parse_params_json(text, "fuzz_config.json");
}
