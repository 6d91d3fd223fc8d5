#include "sim/io/atomic_file.h"

#include <filesystem>
#include <fstream>

#include "sim/input_error.h"

namespace pliant {

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(InputErrorKind::io, path, "cannot open '" + tmp + "' for writing");
    out << text;
    out.flush();
    if (!out) throw InputError(InputErrorKind::io, path, "write failed");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw InputError(InputErrorKind::io, path, "cannot rename temporary file into place: " + ec.message());
  }
}

}  // namespace pliant
