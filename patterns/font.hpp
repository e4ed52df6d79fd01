// A tiny built-in 5x7 bitmap font (digits, upper-case letters and the punctuation the
// pattern and plot labels need), so labels need no font library. Lower-case letters are
// drawn as upper case; unknown characters as a hollow box.
#pragma once

#include <functional>
#include <string_view>

namespace hdrd::patterns {

inline constexpr int kGlyphWidth = 5;
inline constexpr int kGlyphHeight = 7;
inline constexpr int kGlyphAdvance = 6;  // one column of spacing

// Rows top to bottom; bit 4 is the leftmost column.
const unsigned char* glyph(char c);

// Width in pixels of `text` drawn at `scale` (each font pixel a scale x scale block).
int text_width(std::string_view text, int scale = 1);

// Calls plot(x, y) for every lit pixel of `text` whose top-left corner is (x, y).
void draw_text(std::string_view text, int x, int y, int scale, const std::function<void(int, int)>& plot);

}  // namespace hdrd::patterns
