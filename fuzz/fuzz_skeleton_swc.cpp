// Fuzz target: SWC skeletons, read and sanitized (skeleton/io.h, skeleton/build.h).
#include "fuzz/fuzz_reader.h"
#include "skeleton/build.h"
#include "skeleton/io.h"

SM_FUZZ_READER(text) {
  (void)sm::build_skeleton(sm::parse_swc(text, "fuzz.swc"));
}
