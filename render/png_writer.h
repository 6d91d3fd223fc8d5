// PNG output through libpng. The file is written under a temporary name next to the target and
// renamed into place, so a reader (a video encoder watching the folder) never sees half a frame.
#pragma once

#include <filesystem>

#include "render/image.h"

namespace pliant {

/// Writes an RGBA8 PNG to `path` (via `path`.tmp and a rename). Throws RenderError naming the
/// file and the libpng or file-system message on failure.
void write_png(const Image& image, const std::filesystem::path& path);

/// Reads a PNG (any libpng-readable colour type) as RGBA8. Throws RenderError naming the file.
Image read_png(const std::filesystem::path& path);

}  // namespace pliant
