// A tiny built-in 5x7 bitmap font for the frame overlay (time, forces, legend labels), drawn on
// the CPU into the finished image: no font files, no GL texture, identical on every machine.
// Upper case, digits and common punctuation; lower-case letters are drawn in upper case and any
// other character as '?'.
#pragma once

#include <string_view>

#include "render/image.h"

namespace pliant {

inline constexpr int kGlyphWidth = 5;   ///< pixels, before scaling
inline constexpr int kGlyphHeight = 7;  ///< pixels, before scaling
inline constexpr int kGlyphAdvance = 6; ///< horizontal step per character (pixels, before scaling)
inline constexpr int kLineHeight = 9;   ///< vertical step per line (pixels, before scaling)

/// Draws `text` with its top-left corner at (x, y), each font pixel a scale x scale square.
void draw_text(Image& image, int x, int y, std::string_view text, Rgba8 colour, int scale = 1);
/// Width of `text` in pixels at this scale.
int text_width(std::string_view text, int scale = 1);
/// True if the font has a glyph for c (after upper-casing).
bool font_has_glyph(char c);

}  // namespace pliant
