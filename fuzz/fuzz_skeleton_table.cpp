// Fuzz target: QSM cylinder tables (CSV with a header, TreeQSM text), read and sanitized
// (skeleton/import/formats.h, skeleton/build.h).
#include "fuzz/fuzz_reader.h"
#include "skeleton/build.h"
#include "skeleton/import/formats.h"

SM_FUZZ_READER(text) {
  (void)sm::build_skeleton(sm::parse_cylinder_table(text, "fuzz.csv"));
}
