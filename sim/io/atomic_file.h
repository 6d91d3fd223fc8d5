// Writing a whole file so that a reader never sees half of it: write "<path>.tmp", then rename.
#pragma once

#include <string>

namespace pliant {

/// Writes `text` to "<path>.tmp" and renames it to `path`; throws InputError(io) on failure.
void write_file_atomically(const std::string& path, const std::string& text);

}  // namespace pliant
