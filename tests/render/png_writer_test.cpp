// PNG output: a lossless round trip through libpng, no temporary file left behind, and a
// RenderError naming the file for an unwritable path or a file that is not a PNG.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "render/png_writer.h"
#include "render/render_error.h"

namespace pliant {
namespace {

namespace fs = std::filesystem;

fs::path out_dir() {
  const fs::path dir = fs::path(PLIANT_BINARY_DIR) / "tests/render/png_out";
  fs::create_directories(dir);
  return dir;
}

TEST(PngWriter, RoundTripIsExactAndLeavesNoTemporary) {
  Image image(7, 5);
  // Every channel value pattern differs per pixel, alpha included.
  for (size_t i = 0; i < image.rgba.size(); ++i) image.rgba[i] = static_cast<std::uint8_t>((i * 37 + 11) % 256);
  const fs::path path = out_dir() / "round_trip.png";
  fs::remove(path);
  write_png(image, path);
  EXPECT_TRUE(fs::exists(path));
  EXPECT_FALSE(fs::exists(fs::path(path.string() + ".tmp")));
  const Image back = read_png(path);
  EXPECT_EQ(back.width, 7);
  EXPECT_EQ(back.height, 5);
  EXPECT_TRUE(back == image);
  // Overwriting an existing frame works (rename replaces it).
  image.set_pixel(0, 0, {1, 2, 3, 4});
  write_png(image, path);
  EXPECT_EQ(read_png(path).pixel(0, 0), (Rgba8{1, 2, 3, 4}));
}

TEST(PngWriter, FailuresNameTheFile) {
  const fs::path missing_dir = out_dir() / "no_such_dir" / "frame.png";
  try {
    write_png(Image(2, 2), missing_dir);
    FAIL() << "writing into a missing folder must fail";
  } catch (const RenderError& e) {
    EXPECT_NE(std::string(e.what()).find("frame.png"), std::string::npos) << e.what();
  }
  EXPECT_THROW(write_png(Image(), out_dir() / "empty.png"), RenderError);

  const fs::path not_png = out_dir() / "not_a.png";
  std::ofstream(not_png) << "hello";
  try {
    read_png(not_png);
    FAIL() << "a text file is not a PNG";
  } catch (const RenderError& e) {
    EXPECT_NE(std::string(e.what()).find("not_a.png"), std::string::npos) << e.what();
  }
}

TEST(ImageDifference, CountsPixelsOverTolerance) {
  Image a(3, 1, {100, 100, 100, 255});
  Image b = a;
  b.set_pixel(0, 0, {105, 100, 100, 255});  // within 5
  b.set_pixel(2, 0, {100, 90, 100, 255});   // 10 off
  const ImageDifference d = compare_images(a, b, 5);
  EXPECT_EQ(d.max_channel_difference, 10);
  EXPECT_EQ(d.pixels_over_tolerance, 1);
  EXPECT_EQ(d.difference.pixel(2, 0), (Rgba8{0, 10, 0, 255}));
  EXPECT_THROW(compare_images(a, Image(2, 1), 0), RenderError);
}

}  // namespace
}  // namespace pliant
