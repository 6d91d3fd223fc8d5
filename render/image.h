// Image: an RGBA8 raster, row 0 at the top (the order PNG files use).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

namespace pliant {

/// An 8-bit RGBA colour.
struct Rgba8 {
  std::uint8_t r = 0, g = 0, b = 0, a = 255;
  bool operator==(const Rgba8&) const = default;
};

/// A width x height RGBA8 image, rows top to bottom, 4 bytes per pixel.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgba;  ///< width * height * 4 bytes

  Image() = default;
  /// A width x height image filled with `fill`.
  Image(int w, int h, Rgba8 fill = {});

  /// Pixel at column x, row y (row 0 at the top).
  Rgba8 pixel(int x, int y) const;
  /// Sets the pixel at column x, row y; ignored outside the image.
  void set_pixel(int x, int y, Rgba8 c);
  /// Blends c over the pixel at (x, y) with opacity alpha in [0, 1]; ignored outside the image.
  void blend_pixel(int x, int y, Rgba8 c, double alpha);
  bool operator==(const Image&) const = default;
};

/// Per-pixel comparison of two images of the same size.
struct ImageDifference {
  int max_channel_difference = 0;  ///< largest |a - b| over all pixels and channels (0..255)
  long pixels_over_tolerance = 0;  ///< pixels whose largest channel difference exceeds the tolerance
  Image difference;                ///< |a - b| per channel (alpha 255), for inspection
};

/// Compares a and b; `tolerance` is the largest per-channel difference a pixel may have and still
/// count as equal. Throws RenderError if the sizes differ.
ImageDifference compare_images(const Image& a, const Image& b, int tolerance);

}  // namespace pliant
