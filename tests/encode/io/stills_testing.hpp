// Helpers for the still-image tests: one scene encoded as the renditions the writers take,
// Debian's decoders run on the files, and small byte readers written for the tests
// (independent of the writers' code).
#pragma once

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "encode/pipeline.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::stilltest {

using Bytes = std::vector<std::uint8_t>;

// A scene-like relative Rec.709 image: a luminance ramp over ~12 stops across x, colour
// that varies with y (saturated primaries near the top, grey at the bottom), a few
// specular highlights up to 40x diffuse white. Smooth, as photographs mostly are.
inline Image scene(int w, int h) {
  Image img(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double level = std::exp2(-8.0 + 12.0 * (x + 0.5) / w);
      const double hue = 6.2831853 * (x * 3.0 / w + y * 1.0 / h);
      const double sat = 0.8 * (1.0 - static_cast<double>(y) / h);
      float* p = img.px(x, y);
      p[0] = static_cast<float>(level * (1 + sat * std::cos(hue)));
      p[1] = static_cast<float>(level * (1 + sat * std::cos(hue - 2.094)));
      p[2] = static_cast<float>(level * (1 + sat * std::cos(hue + 2.094)));
      p[3] = 1.0f;
      if ((x / 7 + y / 5) % 23 == 0) p[0] = p[1] = p[2] = 40.0f;  // highlights
    }
  return img;
}

// The scene encoded for `mode` with the mode's defaults (REFERENCE.md §1.8).
inline EncodedFrame rendition(const Image& scene_image, Mode mode, Range range = Range::full, bool png_samples = true) {
  EncodeSettings s;
  s.target = default_target(mode);
  s.target.range = range;
  s.png_samples = png_samples;
  s.keep_display_nits = true;
  s.threads = 2;
  SceneInput in;
  in.image = &scene_image;
  auto f = encode_frame(in, s);
  if (!f) throw std::runtime_error(f.error().message);
  return std::move(*f);
}

inline bool have_tool(const std::string& name) {
  return testing::run_command("command -v " + name + " >/dev/null 2>&1").exit_code == 0;
}
#define HDRD_REQUIRE_TOOL(name, package) \
  if (!::hdrd::stilltest::have_tool(name)) GTEST_SKIP() << name << " not installed (Debian package " << package << ")"

inline void write_bytes(const std::filesystem::path& p, const Bytes& b) {
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(b.data()), static_cast<std::streamsize>(b.size()));
}
inline Bytes read_bytes(const std::filesystem::path& p) {
  const std::string s = testing::read_file(p);
  return Bytes(s.begin(), s.end());
}

inline std::uint64_t be(const Bytes& b, std::size_t at, int n) {
  if (at + static_cast<std::size_t>(n) > b.size()) throw std::runtime_error("read past the end");
  std::uint64_t v = 0;
  for (int i = 0; i < n; ++i) v = (v << 8) | b[at + static_cast<std::size_t>(i)];
  return v;
}

// The line of `text` that contains `key`, or "".
inline std::string line_with(const std::string& text, const std::string& key) {
  const auto at = text.find(key);
  if (at == std::string::npos) return {};
  const auto begin = text.rfind('\n', at);
  const auto end = text.find('\n', at);
  return text.substr(begin == std::string::npos ? 0 : begin + 1, end == std::string::npos ? std::string::npos
                                                                                         : end - (begin == std::string::npos ? 0 : begin + 1));
}

}  // namespace hdrd::stilltest
