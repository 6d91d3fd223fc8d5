// libFuzzer target: TetGen .node + .ele. The reader has no in-memory variant, so the input is split
// at its first NUL byte into the two files (no NUL: all of it is the .node, the .ele is empty),
// written to a per-process temporary base name, and read with read_tetgen.
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <string>

#include "fuzz/fuzz_guard.h"
#include "sim/io/tetgen_format.h"

namespace {

void write(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const unsigned char* data, size_t size) {
  static const std::string base = "/tmp/pliant_tetgen_fuzz_" + std::to_string(::getpid());
  const std::string text = pliant::fuzz::as_text(data, size);
  const size_t split = text.find('\0');
  write(base + ".node", text.substr(0, split));
  write(base + ".ele", split == std::string::npos ? std::string() : text.substr(split + 1));
  pliant::fuzz::expect_only_input_errors("tetgen_fuzz", [&] { pliant::read_tetgen(base + ".node"); });
  return 0;
}
