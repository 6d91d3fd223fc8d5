// libFuzzer target: legacy VTK unstructured-grid text through read_vtk_legacy_text.
#include "fuzz/fuzz_guard.h"
#include "sim/io/vtk_legacy_format.h"

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  pliant::fuzz::expect_only_input_errors("vtk_legacy_fuzz", [&] {
    pliant::read_vtk_legacy_text("fuzz.vtk", pliant::fuzz::as_text(data, size));
  });
  return 0;
}
