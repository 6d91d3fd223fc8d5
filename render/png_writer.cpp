#include "render/png_writer.h"

#include <png.h>

#include <cstring>
#include <string>
#include <system_error>

#include "render/render_error.h"

namespace pliant {

void write_png(const Image& image, const std::filesystem::path& path) {
  if (image.width <= 0 || image.height <= 0) {
    throw RenderError(path.string() + ": cannot write an empty image");
  }
  std::filesystem::path temporary = path;
  temporary += ".tmp";

  png_image png;
  std::memset(&png, 0, sizeof(png));
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  png.format = PNG_FORMAT_RGBA;
  // Frames are written at video rate: speed over size (libpng's fast filter and zlib setting).
  png.flags = PNG_IMAGE_FLAG_FAST;
  const int ok = png_image_write_to_file(&png, temporary.c_str(), 0, image.rgba.data(),
                                         static_cast<png_int_32>(image.width) * 4, nullptr);
  if (ok == 0) {
    const std::string message = png.message;
    png_image_free(&png);
    std::error_code ignored;
    std::filesystem::remove(temporary, ignored);
    throw RenderError(path.string() + ": cannot write PNG: " + message);
  }
  std::error_code ec;
  std::filesystem::rename(temporary, path, ec);
  if (ec) {
    std::filesystem::remove(temporary, ec);
    throw RenderError(path.string() + ": cannot rename " + temporary.filename().string() +
                      " into place: " + ec.message());
  }
}

Image read_png(const std::filesystem::path& path) {
  png_image png;
  std::memset(&png, 0, sizeof(png));
  png.version = PNG_IMAGE_VERSION;
  if (png_image_begin_read_from_file(&png, path.c_str()) == 0) {
    throw RenderError(path.string() + ": cannot read PNG: " + png.message);
  }
  png.format = PNG_FORMAT_RGBA;
  Image image(static_cast<int>(png.width), static_cast<int>(png.height));
  if (png_image_finish_read(&png, nullptr, image.rgba.data(), static_cast<png_int_32>(png.width) * 4,
                            nullptr) == 0) {
    const std::string message = png.message;
    png_image_free(&png);
    throw RenderError(path.string() + ": cannot decode PNG: " + message);
  }
  return image;
}

}  // namespace pliant
