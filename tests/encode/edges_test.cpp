// Issue 15, "correctness at the edges", through the public encoder against the standards'
// equations written out in tests/testing/standards.hpp: the HLG displayable volume (the
// EXR dump is what BT.2100's EOTF shows from the codes), HLG black level codes, BT.2390's
// black lift per channel, 16-bit PNG black, SDR content EOTFs in the UI.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>

#include <unistd.h>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "tests/testing/standards.hpp"

using namespace hdrd;
namespace standard = hdrd::testing::standard;

namespace {

std::array<int, 3> codes_at(const EncodedFrame& f, int x, int y) {
  const std::uint8_t* p = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes + static_cast<std::size_t>(x) * 4;
  if (f.drm_fourcc == kDrmFormatXrgb8888) return {p[2], p[1], p[0]};
  std::uint32_t w;
  std::memcpy(&w, p, 4);
  return {static_cast<int>(w & 1023), static_cast<int>((w >> 10) & 1023), static_cast<int>((w >> 20) & 1023)};
}

// Display light (Rec.2020 cd/m2, or relative with `relative`) in, through clip: no tone mapping.
Result<EncodedFrame> encode_light(const Image& img, const DisplayTarget& t, const std::string& curve = "clip",
                                  bool keep_nits = true) {
  EncodeSettings s;
  s.target = t;
  s.tone.curve = curve;
  s.keep_display_nits = keep_nits;
  s.threads = 1;
  SceneInput in;
  in.image = &img;
  in.to_working = color::Mat3::identity();
  in.units = InputUnits::absolute;
  in.white_luminance_nits = 1.0;
  return encode_frame(in, s);
}

struct TempDir {
  std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("hdrd-edges-" + std::to_string(::getpid()) + "-" +
                                                std::to_string(reinterpret_cast<std::uintptr_t>(this)));
  TempDir() { std::filesystem::create_directories(path); }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
};

// Saturated Rec.2020 colours (primaries, secondaries, two in between) at fractions of the
// peak and above it, one per column.
Image saturated_colours(double peak_nits) {
  const color::Vec3 hues[] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {0, 1, 1}, {1, 0, 1}, {1, 1, 0}, {1, 0.3, 0}, {0, 0.5, 1}};
  const double levels[] = {0.2, 0.4, 0.57, 0.8, 1.0, 1.5};
  Image img(static_cast<int>(std::size(hues) * std::size(levels)), 2);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      const color::Vec3 c = hues[x % std::size(hues)] * (levels[x / std::size(hues)] * peak_nits);
      float* p = img.px(x, y);
      p[0] = float(c.x), p[1] = float(c.y), p[2] = float(c.z), p[3] = 1;
    }
  return img;
}

// The case: a Rec.2020 blue of 800 cd/m2 on a 1000 cd/m2 HLG display encoded to
// (0, 0, 1023), which BT.2100's EOTF shows at 569 cd/m2 while the dump said 800. Now the
// dump says what the codes show, at several peaks and black levels, read back from the EXR
// file and decoded from the raw codes with BT.2100's EOTF written out in the test.
TEST(HlgVolume, ExrDumpIsWhatTheBt2100EotfShowsFromTheCodes) {
  TempDir dir;
  for (double peak : {400.0, 1000.0, 2000.0, 4000.0})
    for (double black : {0.0, 0.01})
      for (const char* curve : {"clip", "pq-shoulder"})
        for (GamutMapping g : {GamutMapping::ictcp, GamutMapping::clip}) {
          SCOPED_TRACE(::testing::Message() << peak << " cd/m2, black " << black << ", " << curve << ", gamut "
                                            << to_string(g));
          DisplayTarget t = default_target(Mode::hlg);
          t.peak_nits = peak, t.black_nits = black;
          const Image img = saturated_colours(peak);
          EncodeSettings s;
          s.target = t;
          s.tone.curve = curve;
          s.gamut = g;
          s.keep_display_nits = true;
          SceneInput in;
          in.image = &img;
          in.to_working = color::Mat3::identity();
          in.units = InputUnits::absolute;
          auto f = encode_frame(in, s);
          ASSERT_TRUE(f.ok()) << f.error().message;
          auto dumps = io::write_dumps(*f, dir.path / "hlg", {io::DumpFormat::exr});
          ASSERT_TRUE(dumps.ok()) << dumps.error().message;
          auto exr = io::read_exr(dumps->files.at("exr"));
          ASSERT_TRUE(exr.ok()) << exr.error().message;
          const double w = *exr->white_luminance;
          for (int x = 0; x < img.width; ++x) {
            const auto c = codes_at(*f, x, 0);
            const auto shown = standard::hlg_eotf({c[0] / 1023.0, c[1] / 1023.0, c[2] / 1023.0}, peak, black);
            const double top = std::max({shown[0], shown[1], shown[2]});
            for (int ch = 0; ch < 3; ++ch) {
              const double dumped = exr->image.px(x, 0)[ch] * w;
              EXPECT_NEAR(dumped, shown[ch], 0.01 * std::max(shown[ch], 0.01 * top) + 1e-3)
                  << "column " << x << " channel " << ch;
            }
          }
        }
}

TEST(HlgVolume, SaturatedBlueKeepsItsLuminance) {
  Image img(1, 1);
  img.rgba = {0, 0, 800, 1};
  auto f = encode_light(img, default_target(Mode::hlg));
  ASSERT_TRUE(f.ok());
  const auto c = codes_at(*f, 0, 0);
  EXPECT_NE(c, (std::array<int, 3>{0, 0, 1023})) << "the blue is clipped";
  const auto shown = standard::hlg_eotf({c[0] / 1023.0, c[1] / 1023.0, c[2] / 1023.0}, 1000, 0);
  // Constant luminance toward grey: Y = 0.0593 x 800 = 47.4 cd/m2 is kept (within the codes).
  EXPECT_NEAR(0.2627 * shown[0] + 0.6780 * shown[1] + 0.0593 * shown[2], 0.0593 * 800, 0.02 * 47.4);
  EXPECT_GT(shown[2], shown[0] * 5);  // still blue
  const float* d = f->display_nits->px(0, 0);
  EXPECT_NEAR(d[2], shown[2], 0.01 * shown[2]);
}

// HLG with a black level: BT.2100's EOTF lifts E' = 0 to beta, so encode inverts it:
// E' = (OETF((L / Lw)^(1 / gamma)) - beta) / (1 - beta) for grey light L.
TEST(HlgBlack, CodesInvertTheLiftedEotf) {
  for (double peak : {1000.0, 4000.0})
    for (double black : {0.005, 0.05, 0.5}) {
      DisplayTarget t = default_target(Mode::hlg);
      t.peak_nits = peak, t.black_nits = black;
      const double levels[] = {0.0, black * 0.5, black, black * 2, 0.1, 1.0, 10.0, 100.0, 203.0, 500.0, peak};
      Image img(static_cast<int>(std::size(levels)), 1);
      for (int x = 0; x < img.width; ++x) {
        float* p = img.px(x, 0);
        p[0] = p[1] = p[2] = float(levels[x]), p[3] = 1;
      }
      auto f = encode_light(img, t);
      ASSERT_TRUE(f.ok());
      for (int x = 0; x < img.width; ++x) {
        const int want = static_cast<int>(std::lround(standard::hlg_grey_signal(levels[x], peak, black) * 1023));
        EXPECT_NEAR(codes_at(*f, x, 0)[1], want, 1) << peak << " / " << black << " at " << levels[x] << " cd/m2";
        // What the display shows for those codes is the dump (black and below: the black
        // level), within the light of one code there (the dump is before quantisation).
        const int c = codes_at(*f, x, 0)[1];
        auto shown = [&](int code) { return standard::hlg_eotf({code / 1023.0, code / 1023.0, code / 1023.0}, peak, black)[1]; };
        const double step = shown(std::min(c + 1, 1023)) - shown(std::max(c - 1, 0));
        EXPECT_NEAR(f->display_nits->px(x, 0)[1], shown(c), 0.5 * step + 1e-6 * peak) << levels[x];
      }
      EXPECT_EQ(codes_at(*f, 0, 0)[0], 0);
      EXPECT_EQ(codes_at(*f, 2, 0)[0], 0);  // the black level itself
      EXPECT_GT(codes_at(*f, 3, 0)[0], 0);  // twice it is above
    }
}

// Every mode: the dump is what the mode's EOTF shows from the codes (BT.1886 with its black
// level shows Lb for code 0, and the dump says so).
TEST(DisplayVolume, EveryModesDumpIsTheDecodedLight) {
  for (Mode m : {Mode::hdr10, Mode::sdr, Mode::sdr_bt1886}) {
    DisplayTarget t = default_target(m);
    t.bits = 10;
    const Image img = saturated_colours(t.peak_nits);
    auto f = encode_light(img, t);
    ASSERT_TRUE(f.ok());
    auto shown = [&](int code) {
      const double e = code / 1023.0;
      if (m == Mode::hdr10) return standard::pq_eotf(e);
      if (m == Mode::sdr) return t.peak_nits * (e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4));
      // BT.1886: L = a max(V + b, 0)^2.4 with a, b from Lw and Lb.
      const double lw = std::pow(t.peak_nits, 1 / 2.4), lb = std::pow(t.black_nits, 1 / 2.4);
      return std::pow(lw - lb, 2.4) * std::pow(std::max(e + lb / (lw - lb), 0.0), 2.4);
    };
    for (int x = 0; x < img.width; ++x) {
      const auto c = codes_at(*f, x, 0);
      for (int ch = 0; ch < 3; ++ch) {
        // The dump holds the light before quantisation: within 1 %, or one code there.
        const double tolerance = std::max(0.01 * shown(c[ch]), shown(std::min(c[ch] + 1, 1023)) - shown(c[ch]));
        EXPECT_NEAR(f->display_nits->px(x, 0)[ch], shown(c[ch]), tolerance) << to_string(m) << " column " << x;
      }
    }
  }
}

// REFERENCE.md §1.7: 16-bit PNG samples are round(E' x 65535); black's E' is 0 in every
// transfer (PQ(0) = 7.3e-7 rounds to 0), so a black frame's PNG holds zeros, whichever
// curve and transfer, read back through libpng.
TEST(PngBlack, SixteenBitBlackIsZeroForEveryTransfer) {
  struct Case { Mode mode; SdrCurve curve; double black; };
  const Case cases[] = {{Mode::hdr10, SdrCurve::srgb, 0.005}, {Mode::hlg, SdrCurve::srgb, 0},
                        {Mode::hlg, SdrCurve::srgb, 0.01},    {Mode::sdr, SdrCurve::srgb, 0.1},
                        {Mode::sdr, SdrCurve::gamma22, 0.1},  {Mode::sdr_bt1886, SdrCurve::srgb, 0},
                        {Mode::sdr_bt1886, SdrCurve::srgb, 0.1}};
  for (const Case& k : cases)
    for (const char* curve : {"clip", "pq-shoulder", "hable", "day", "aces-narkowicz", "bt2390", "agx"}) {
      DisplayTarget t = default_target(k.mode);
      t.bits = 10, t.sdr_curve = k.curve, t.black_nits = k.black;
      Image img(4, 2);
      for (std::size_t i = 0; i < img.pixel_count(); ++i) img.rgba[i * 4 + 3] = 1;
      EncodeSettings s;
      s.target = t;
      s.tone.curve = curve;
      SceneInput in;
      in.image = &img;
      auto f = encode_frame(in, s);
      ASSERT_TRUE(f.ok()) << f.error().message;
      auto png = io::encode_png(*f);
      ASSERT_TRUE(png.ok());
      auto info = io::read_png_info_memory(*png);
      ASSERT_TRUE(info.ok());
      ASSERT_EQ(info->bit_depth, 16);
      for (std::uint16_t v : info->samples)
        ASSERT_EQ(v, 0) << to_string(k.mode) << " " << to_string(k.curve) << " black " << k.black << " " << curve;
      EXPECT_EQ(codes_at(*f, 0, 0), (std::array<int, 3>{0, 0, 0})) << to_string(k.mode) << " " << curve;
    }
}

// BT.2390 with the black lift, applied as max-rgb, through the encoder: every channel
// carries the report's E3, so black and the zero channels of near-black colours come out
// at the display black (0.05 cd/m2), and grey at the report's value.
TEST(Bt2390Lift, EncoderCodesAreTheReportsPerChannel) {
  const standard::Bt2390Report r{0, 1000, 0.05, 600};
  DisplayTarget t = default_target(Mode::hdr10);
  t.peak_nits = 600, t.black_nits = 0.05;
  const color::Vec3 colours[] = {{0, 0, 0}, {0.001, 0, 0}, {0.01, 0.002, 0}, {0.1, 0.1, 0.1}, {1, 1, 1}, {3, 0.5, 0.1}};
  Image img(static_cast<int>(std::size(colours)), 1);
  for (int x = 0; x < img.width; ++x) {
    float* p = img.px(x, 0);
    p[0] = float(colours[x].x), p[1] = float(colours[x].y), p[2] = float(colours[x].z), p[3] = 1;
  }
  for (bool staged : {false, true}) {
    EncodeSettings s;
    s.target = t;
    s.tone.curve = "bt2390";
    s.tone.params = {{"source_peak_nits", 1000}, {"black_lift", 1}};
    s.staged_only = staged;  // the staged path; otherwise the fused kernel
    SceneInput in;
    in.image = &img;
    in.to_working = color::Mat3::identity();
    auto f = encode_frame(in, s);
    ASSERT_TRUE(f.ok()) << f.error().message;
    for (int x = 0; x < img.width; ++x) {
      const color::Vec3 c = colours[x] * 203.0;
      const double m = std::max({c.x, c.y, c.z});
      const double ratio = m > 0 ? r.rolloff(m) / m : 0;
      const auto got = codes_at(*f, x, 0);
      for (int ch = 0; ch < 3; ++ch) {
        const int want = static_cast<int>(std::lround(standard::pq_inverse_eotf(r.lift(c[ch] * ratio)) * 1023));
        EXPECT_NEAR(got[ch], want, 1) << (staged ? "staged" : "fused") << " colour " << x << " channel " << ch;
      }
    }
    EXPECT_EQ(codes_at(*f, 0, 0)[0], std::lround(standard::pq_inverse_eotf(0.05) * 1023));
  }
}

// SDR content in an HDR frame (the UI) decoded with the EOTF it was mastered for: at UI
// white 203 cd/m2 an 8-bit code of 10 is 0.616 cd/m2 in sRGB, 0.163 in gamma 2.2, 0.085 in
// BT.1886 (2.4), and the codes say so.
TEST(SdrContent, UiDecodesWithTheSdrContentEotf) {
  const int ui_codes[] = {0, 3, 10, 26, 51, 128, 255};
  auto overlay = std::make_shared<OverlayImage>();
  overlay->width = static_cast<int>(std::size(ui_codes));
  overlay->height = 1;
  for (int c : ui_codes) overlay->rgba.insert(overlay->rgba.end(), {c / 255.0f, c / 255.0f, c / 255.0f, 1.0f});
  auto relative = [](SdrEotf e, double v) {
    if (e == SdrEotf::srgb) return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4);  // IEC 61966-2-1
    return std::pow(v, e == SdrEotf::gamma22 ? 2.2 : 2.4);                                       // 2.2; BT.1886, Lb = 0
  };
  for (SdrEotf e : {SdrEotf::srgb, SdrEotf::gamma22, SdrEotf::bt1886})
    for (bool fused : {true, false}) {
      DisplayTarget t = default_target(Mode::hdr10);
      t.sdr_content_eotf = e;
      Image black(overlay->width, 1);
      EncodeSettings s;
      s.target = t;
      s.tone.curve = "clip";
      s.ui.overlay = overlay;
      s.staged_only = !fused;
      SceneInput in;
      in.image = &black;
      auto f = encode_frame(in, s);
      ASSERT_TRUE(f.ok());
      for (int x = 0; x < overlay->width; ++x) {
        const double nits = t.ui_white_nits * relative(e, ui_codes[x] / 255.0);
        const int want = static_cast<int>(std::lround(standard::pq_inverse_eotf(nits) * 1023));
        EXPECT_NEAR(codes_at(*f, x, 0)[1], want, 1) << to_string(e) << " code " << ui_codes[x];
      }
    }
  EXPECT_EQ(parse_sdr_eotf("gamma22"), SdrEotf::gamma22);
  EXPECT_EQ(parse_sdr_eotf("bt1886"), SdrEotf::bt1886);
  EXPECT_FALSE(parse_sdr_eotf("gamma24"));
}

}  // namespace
