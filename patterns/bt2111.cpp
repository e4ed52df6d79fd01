// ITU-R BT.2111-2 "Specification of colour bar test pattern for high dynamic range
// television systems": the PQ and HLG narrow-range variants. Levels are the standard's
// signal percentages; codes follow BT.2100 Table 9 (D = round((219 E' + 16) 2^(n-8))).
// The BT.709 bars of the bottom row are 100 % BT.709 colours converted to BT.2020 and
// placed at the standard's reference white: HLG 75 % (scene light 0.2650) and PQ 58 %,
// converted with the BT.2087 matrix.
#include <array>
#include <cmath>
#include <stdexcept>

#include "encode/colour/color.hpp"
#include "encode/colour/transfer.hpp"
#include "patterns/patterns.hpp"

namespace hdrd::patterns {
namespace {

constexpr int kBits = 10;

int narrow(double signal) { return transfer::quantize_narrow(signal, kBits); }
Code3 grey(int code) { return {code, code, code}; }
Code3 grey_percent(double percent) { return grey(narrow(percent / 100.0)); }

// The bars' reference level: HLG 75 %, PQ 58 % (BT.2111-2 §1, = BT.2408 reference white).
double bar_percent(Bt2111System s) { return s == Bt2111System::hlg ? 75.0 : 58.0; }

// A BT.709 colour (linear, 1.0 = reference white) in the BT.2020 container at the
// system's reference white level.
Code3 bt709_bar(Bt2111System s, color::Vec3 rec709) {
  // BT.2111-2 converts with the BT.2087 matrix as published (4 decimals); the derived
  // matrix moves the HLG green bar's G by one code (707 instead of the table's 706).
  const color::Vec3 c = color::kBt2087Rec709ToRec2020 * rec709;
  auto code = [&](double v) {
    v = std::max(v, 0.0);
    if (s == Bt2111System::hlg) return narrow(transfer::hlg_oetf(v * transfer::hlg_inverse_oetf(0.75)));
    return narrow(transfer::pq_inverse_eotf(v * transfer::pq_eotf(0.58)));
  };
  return {code(c.x), code(c.y), code(c.z)};
}

Code3 colour_bar(double percent, bool r, bool g, bool b) {
  const int on = narrow(percent / 100.0), off = narrow(0.0);
  return {r ? on : off, g ? on : off, b ? on : off};
}

struct Bar {
  const char* level;
  int width_1920;  // width in the 1920-wide layout of the standard
};

// Rows (heights as fractions of the picture: 1/12, 1/2, 1/12, 1/12, 1/4).
constexpr std::array<Bar, 9> kRow1{{{"40% grey", 240}, {"100% white", 206}, {"100% yellow", 206},
                                    {"100% cyan", 206}, {"100% green", 204}, {"100% magenta", 206},
                                    {"100% red", 206}, {"100% blue", 206}, {"40% grey", 240}}};
constexpr std::array<Bar, 9> kRow2{{{"40% grey", 240}, {"ref white", 206}, {"ref yellow", 206},
                                    {"ref cyan", 206}, {"ref green", 204}, {"ref magenta", 206},
                                    {"ref red", 206}, {"ref blue", 206}, {"40% grey", 240}}};
constexpr std::array<Bar, 15> kRow3{{{"ref grey", 240}, {"-7% grey", 206}, {"0% grey", 103}, {"10% grey", 103},
                                     {"20% grey", 103}, {"30% grey", 103}, {"40% grey", 102}, {"50% grey", 102},
                                     {"60% grey", 103}, {"70% grey", 103}, {"80% grey", 103}, {"90% grey", 103},
                                     {"100% grey", 103}, {"109% grey", 103}, {"ref grey", 240}}};
constexpr std::array<Bar, 15> kRow5{{{"709 yellow", 80}, {"709 cyan", 80}, {"709 green", 80}, {"0% grey", 136},
                                     {"-2% grey", 70}, {"0% grey", 68}, {"+2% grey", 70}, {"0% grey", 68},
                                     {"+4% grey", 70}, {"0% grey", 238}, {"ref grey", 438}, {"0% grey", 282},
                                     {"709 magenta", 80}, {"709 red", 80}, {"709 blue", 80}}};
// Row 4: 0 % black (240), -7 % (559), a ramp (1014), 109 % (107). At 1920 pixels the ramp
// rises one code per pixel from 5 to 1018, between the -7 % (4) and 109 % (1019) patches.
constexpr int kRow4Black = 240, kRow4Low = 559, kRow4Ramp = 1014;
constexpr int kRampFirst = 5, kRampLast = 1018;

}  // namespace

Code3 bt2111_code(Bt2111System s, std::string_view level) {
  const double ref = bar_percent(s);
  if (level == "ref white" || level == "ref grey") return grey_percent(ref);
  // The extremes BT.2100 Table 9 permits in 10-bit narrow range (codes 0-3 and 1020-1023
  // are reserved for timing): BT.2111-2 labels them -7 % and 109 %.
  if (level == "-7% grey") return grey(4);
  if (level == "109% grey") return grey(1019);
  // Near-black PLUGE steps, given by the standard as 10-bit codes 48, 80 and 99.
  if (level == "-2% grey") return grey(48);
  if (level == "+2% grey") return grey(80);
  if (level == "+4% grey") return grey(99);
  struct Colour { const char* name; bool r, g, b; };
  static constexpr Colour kColours[] = {{"white", 1, 1, 1}, {"yellow", 1, 1, 0}, {"cyan", 0, 1, 1}, {"green", 0, 1, 0},
                                        {"magenta", 1, 0, 1}, {"red", 1, 0, 0}, {"blue", 0, 0, 1}};
  for (const auto& c : kColours) {
    const std::string name = c.name;
    if (level == "100% " + name) return colour_bar(100, c.r, c.g, c.b);
    if (level == "ref " + name) return colour_bar(ref, c.r, c.g, c.b);
    if (level == "709 " + name) return bt709_bar(s, {double(c.r), double(c.g), double(c.b)});
  }
  if (level.size() > 6 && level.substr(level.size() - 6) == "% grey")
    return grey_percent(std::stod(std::string(level.substr(0, level.size() - 6))));
  throw std::invalid_argument("bt2111: unknown level '" + std::string(level) + "'");
}

std::vector<std::string> bt2111_levels() {
  std::vector<std::string> out;
  for (const auto* row : {kRow1.data(), kRow2.data()})
    for (int i = 0; i < 9; ++i) out.emplace_back(row[i].level);
  for (const auto* row : {kRow3.data(), kRow5.data()})
    for (int i = 0; i < 15; ++i) out.emplace_back(row[i].level);
  return out;
}

std::vector<Code3> bt2111_codes(Bt2111System s, int width, int height) {
  std::vector<Code3> out(static_cast<std::size_t>(width) * height);
  auto x_at = [&](int x1920) { return static_cast<int>(std::lround(double(x1920) * width / 1920.0)); };
  auto fill_row = [&](int y0, int y1, const Bar* bars, int n) {
    int cum = 0;
    for (int i = 0; i < n; ++i) {
      const int xa = x_at(cum), xb = x_at(cum + bars[i].width_1920);
      cum += bars[i].width_1920;
      const Code3 c = bt2111_code(s, bars[i].level);
      for (int y = y0; y < y1; ++y)
        for (int x = xa; x < xb; ++x) out[static_cast<std::size_t>(y) * width + x] = c;
    }
  };
  auto y_at = [&](int twelfths) { return static_cast<int>(std::lround(double(twelfths) * height / 12.0)); };
  fill_row(0, y_at(1), kRow1.data(), 9);
  fill_row(y_at(1), y_at(7), kRow2.data(), 9);
  fill_row(y_at(7), y_at(8), kRow3.data(), 15);
  // Row 4: the ramp from code 5 to 1018 across its width (one code per pixel at 1920).
  const int x1 = x_at(kRow4Black), x2 = x_at(kRow4Black + kRow4Low), x3 = x_at(kRow4Black + kRow4Low + kRow4Ramp);
  const double ramp_step = double(kRampLast - kRampFirst) / std::max(1, x3 - x2 - 1);
  for (int y = y_at(8); y < y_at(9); ++y)
    for (int x = 0; x < width; ++x) {
      int code;
      if (x < x1) code = narrow(0.0);
      else if (x < x2) code = 4;
      else if (x < x3) code = kRampFirst + static_cast<int>(std::lround(ramp_step * (x - x2)));
      else code = 1019;
      out[static_cast<std::size_t>(y) * width + x] = grey(code);
    }
  fill_row(y_at(9), height, kRow5.data(), 15);
  return out;
}

}  // namespace hdrd::patterns
