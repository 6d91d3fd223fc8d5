// Overlay pieces drawn on the CPU: the bitmap font (ink inside each 5x7 cell, upper and lower case
// alike, unknown characters as '?', widths) and the viridis colour map (its table values at the
// ends, luminance rising monotonically, clamping).
#include <gtest/gtest.h>

#include <cmath>

#include "render/bitmap_font.h"
#include "render/colour_map.h"

namespace pliant {
namespace {

constexpr Rgba8 kPaper{0, 0, 0, 255};
constexpr Rgba8 kInk{255, 255, 255, 255};

long ink_pixels(const Image& image) {
  long n = 0;
  for (int y = 0; y < image.height; ++y) {
    for (int x = 0; x < image.width; ++x) n += image.pixel(x, y) == kInk ? 1 : 0;
  }
  return n;
}

TEST(BitmapFont, EveryGlyphStaysInsideItsCellAndHasInk) {
  const std::string printable = "0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZ.,:-+=/()%_[]<>*|?";
  for (char c : printable) {
    ASSERT_TRUE(font_has_glyph(c)) << c;
    Image image(kGlyphWidth + 4, kGlyphHeight + 4, kPaper);
    draw_text(image, 2, 2, std::string(1, c), kInk);
    EXPECT_GT(ink_pixels(image), 0) << c;
    for (int y = 0; y < image.height; ++y) {
      for (int x = 0; x < image.width; ++x) {
        const bool inside = x >= 2 && x < 2 + kGlyphWidth && y >= 2 && y < 2 + kGlyphHeight;
        if (!inside) {
          EXPECT_EQ(image.pixel(x, y), kPaper) << c << " at " << x << "," << y;
        }
      }
    }
  }
}

TEST(BitmapFont, LowerCaseDrawsAsUpperAndUnknownAsQuestionMark) {
  Image lower(40, 10, kPaper), upper(40, 10, kPaper), unknown(10, 10, kPaper), question(10, 10, kPaper);
  draw_text(lower, 0, 0, "step ms", kInk);
  draw_text(upper, 0, 0, "STEP MS", kInk);
  EXPECT_TRUE(lower == upper);
  draw_text(unknown, 0, 0, "~", kInk);
  draw_text(question, 0, 0, "?", kInk);
  EXPECT_TRUE(unknown == question);
  EXPECT_FALSE(font_has_glyph('~'));
}

TEST(BitmapFont, ScaleMultipliesInkAndWidth) {
  Image one(20, 20, kPaper), two(20, 20, kPaper);
  draw_text(one, 0, 0, "8", kInk, 1);
  draw_text(two, 0, 0, "8", kInk, 2);
  EXPECT_EQ(ink_pixels(two), 4 * ink_pixels(one));
  EXPECT_EQ(text_width("AB", 1), 2 * kGlyphAdvance - 1);
  EXPECT_EQ(text_width("AB", 3), 3 * (2 * kGlyphAdvance - 1));
  EXPECT_EQ(text_width("", 2), 0);
}

double luminance(Rgba8 c) { return 0.2126 * c.r + 0.7152 * c.g + 0.0722 * c.b; }

TEST(ColourMap, ViridisEndsAndMonotoneLuminance) {
  EXPECT_EQ(colour_map(0.0), (Rgba8{68, 1, 84, 255}));
  EXPECT_EQ(colour_map(1.0), (Rgba8{253, 231, 37, 255}));
  EXPECT_EQ(colour_map(-3.0), colour_map(0.0));
  EXPECT_EQ(colour_map(7.0), colour_map(1.0));
  EXPECT_EQ(colour_map(std::nan("")), colour_map(0.0));
  double previous = -1.0;
  for (int i = 0; i <= 100; ++i) {
    const double l = luminance(colour_map(i / 100.0));
    EXPECT_GT(l, previous) << "t = " << i / 100.0;
    previous = l;
  }
  EXPECT_DOUBLE_EQ(normalised(5.0, 0.0, 10.0), 0.5);
  EXPECT_DOUBLE_EQ(normalised(5.0, 1.0, 1.0), 0.0);
}

}  // namespace
}  // namespace pliant
