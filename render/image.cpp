#include "render/image.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>

#include "render/render_error.h"

namespace pliant {

Image::Image(int w, int h, Rgba8 fill) : width(w), height(h) {
  rgba.resize(static_cast<size_t>(w) * static_cast<size_t>(h) * 4u);
  for (size_t i = 0; i < rgba.size(); i += 4) {
    rgba[i] = fill.r;
    rgba[i + 1] = fill.g;
    rgba[i + 2] = fill.b;
    rgba[i + 3] = fill.a;
  }
}

Rgba8 Image::pixel(int x, int y) const {
  const size_t i = (static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) * 4u;
  return {rgba[i], rgba[i + 1], rgba[i + 2], rgba[i + 3]};
}

void Image::set_pixel(int x, int y, Rgba8 c) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  const size_t i = (static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) * 4u;
  rgba[i] = c.r;
  rgba[i + 1] = c.g;
  rgba[i + 2] = c.b;
  rgba[i + 3] = c.a;
}

void Image::blend_pixel(int x, int y, Rgba8 c, double alpha) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  const Rgba8 p = pixel(x, y);
  const auto mix = [alpha](std::uint8_t under, std::uint8_t over) {
    return static_cast<std::uint8_t>(std::lround((1.0 - alpha) * under + alpha * over));
  };
  set_pixel(x, y, {mix(p.r, c.r), mix(p.g, c.g), mix(p.b, c.b), p.a});
}

ImageDifference compare_images(const Image& a, const Image& b, int tolerance) {
  if (a.width != b.width || a.height != b.height) {
    throw RenderError("compare_images: sizes differ (" + std::to_string(a.width) + "x" +
                      std::to_string(a.height) + " vs " + std::to_string(b.width) + "x" +
                      std::to_string(b.height) + ")");
  }
  ImageDifference d;
  d.difference = Image(a.width, a.height, {0, 0, 0, 255});
  for (size_t i = 0; i < a.rgba.size(); i += 4) {
    int pixel_max = 0;
    for (size_t c = 0; c < 4; ++c) {
      const int diff = std::abs(int{a.rgba[i + c]} - int{b.rgba[i + c]});
      pixel_max = std::max(pixel_max, diff);
      if (c < 3) d.difference.rgba[i + c] = static_cast<std::uint8_t>(diff);
    }
    d.max_channel_difference = std::max(d.max_channel_difference, pixel_max);
    if (pixel_max > tolerance) ++d.pixels_over_tolerance;
  }
  return d;
}

}  // namespace pliant
