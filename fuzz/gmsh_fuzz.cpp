// libFuzzer target: Gmsh .msh text (2.2 and 4.1 ASCII) through read_gmsh_text.
#include "fuzz/fuzz_guard.h"
#include "sim/io/gmsh_format.h"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  pliant::fuzz::expect_only_input_errors("gmsh_fuzz", [&] {
    pliant::read_gmsh_text("fuzz.msh", pliant::fuzz::as_text(data, size));
  });
  return 0;
}
