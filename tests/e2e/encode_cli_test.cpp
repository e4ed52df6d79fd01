// `hdrd encode` end to end: held-out colours against an independent implementation of
// REFERENCE.md §1 written here from the published constants (not calling encode/), the
// fixture pair Rec709.exr / XYZ.exr, and bad input (one clear line, exit != 0, no files).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "tests/testing/testing.hpp"

namespace fs = std::filesystem;
using hdrd::testing::run_command;
using hdrd::testing::TempDir;

namespace {

// ---- the independent implementation --------------------------------------------------
// ST 2084 constants as published; BT.2087 Rec.709 -> Rec.2020 matrix (4 decimals).
double pq(double nits) {
  const double m1 = 0.1593017578125, m2 = 78.84375, c1 = 0.8359375, c2 = 18.8515625, c3 = 18.6875;
  const double y = std::pow(std::max(nits, 0.0) / 10000.0, m1);
  return std::pow((c1 + c2 * y) / (1 + c3 * y), m2);
}
const double kBt2087[3][3] = {{0.6274, 0.3293, 0.0433}, {0.0691, 0.9195, 0.0114}, {0.0164, 0.0880, 0.8956}};
double srgb(double l) { return l <= 0.0031308 ? 12.92 * l : 1.055 * std::pow(l, 1 / 2.4) - 0.055; }

std::string hdrd() { return hdrd::testing::hdrd_binary().string(); }

std::vector<std::uint8_t> slurp(const fs::path& p) {
  const std::string s = hdrd::testing::read_file(p);
  return {s.begin(), s.end()};
}

// A float32 EXR of random relative Rec.709 colours (exact values, no half rounding).
hdrd::Image held_out_colours(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 6.0);
  hdrd::Image img(n, 1);
  for (int i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) img.rgba[i * 4 + c] = static_cast<float>(i % 7 == 0 ? u(rng) / 30 : u(rng));
    img.rgba[i * 4 + 3] = 1;
  }
  return img;
}

void write_input(const fs::path& p, const hdrd::Image& img) {
  hdrd::io::ExrWriteOptions o;
  o.half = false;
  ASSERT_TRUE(hdrd::io::write_exr(p, img, o).ok());
}

std::uint32_t word_at(const std::vector<std::uint8_t>& raw, int i) {
  std::uint32_t w;
  std::memcpy(&w, raw.data() + i * 4, 4);
  return w;
}

TEST(EncodeCli, Hdr10ClipMatchesAnIndependentImplementation) {
  TempDir tmp;
  const auto img = held_out_colours(500, 11);
  write_input(tmp / "in.exr", img);
  for (const char* range : {"full", "narrow"}) {
    for (double peak : {600.0, 1000.0, 4000.0}) {
      const auto r = run_command(hdrd() + " encode " + (tmp / "in.exr").string() + " -o " + (tmp / "o").string() +
                                 " --mode hdr10 --tonemap clip --format raw -q --range " + range +
                                 " --peak " + std::to_string(peak));
      ASSERT_EQ(r.exit_code, 0) << r.err;
      const auto raw = slurp(tmp / "o.raw");
      ASSERT_EQ(raw.size(), 500u * 4);
      for (int i = 0; i < 500; ++i) {
        const std::uint32_t w = word_at(raw, i);
        for (int c = 0; c < 3; ++c) {
          double rel = 0;
          for (int k = 0; k < 3; ++k) rel += kBt2087[c][k] * img.rgba[i * 4 + k];
          const double nits = std::min(rel * 203.0, peak);
          const double e = pq(nits);
          const long want = std::string(range) == "full" ? std::lround(e * 1023) : std::lround((219 * e + 16) * 4);
          EXPECT_LE(std::labs(static_cast<long>((w >> (10 * c)) & 1023) - want), 1) << "pixel " << i << " ch " << c;
        }
      }
    }
  }
}

TEST(EncodeCli, ScrgbSdrAndHlgMatchIndependentFormulas) {
  TempDir tmp;
  const auto img = held_out_colours(300, 12);
  write_input(tmp / "in.exr", img);
  const std::string base = hdrd() + " encode " + (tmp / "in.exr").string() + " -o " + (tmp / "o").string() +
                           " --tonemap clip --format raw -q";
  // scRGB: Rec.709 primaries, value = nits / 80, 1.0 relative = 203 cd/m2, clipped at 1000.
  ASSERT_EQ(run_command(base + " --mode scrgb").exit_code, 0);
  auto raw = slurp(tmp / "o.raw");
  ASSERT_EQ(raw.size(), 300u * 8);
  for (int i = 0; i < 300; ++i)
    for (int c = 0; c < 3; ++c) {
      std::uint16_t h;
      std::memcpy(&h, raw.data() + i * 8 + c * 2, 2);
      // decode binary16 by hand
      const int e = (h >> 10) & 31, m = h & 1023;
      const double v = (e == 0 ? m / 1024.0 * std::pow(2.0, -14) : (1 + m / 1024.0) * std::pow(2.0, e - 15));
      double rel2020[3];
      for (int k = 0; k < 3; ++k) {
        rel2020[k] = 0;
        for (int j = 0; j < 3; ++j) rel2020[k] += kBt2087[k][j] * img.rgba[i * 4 + j];
      }
      // clip happens per channel in Rec.2020; back in Rec.709 only unclipped channels are exact.
      if (std::max({rel2020[0], rel2020[1], rel2020[2]}) * 203 < 1000) {
        EXPECT_NEAR(v, img.rgba[i * 4 + c] * 203 / 80.0, 2e-3 * v + 1e-4) << i;
      }
    }
  // SDR: sRGB of min(nits / 100, 1) (paper white = peak = 100), 8-bit, XRGB8888.
  ASSERT_EQ(run_command(base + " --mode sdr").exit_code, 0);
  raw = slurp(tmp / "o.raw");
  for (int i = 0; i < 300; ++i) {
    bool in_range = true;
    for (int c = 0; c < 3; ++c) in_range = in_range && img.rgba[i * 4 + c] < 0.98;
    if (!in_range) continue;  // above white: clipped in Rec.2020, then gamut mapped
    for (int c = 0; c < 3; ++c) {
      const long want = std::lround(srgb(img.rgba[i * 4 + c]) * 255);
      EXPECT_LE(std::labs(raw[i * 4 + 2 - c] - want), 1) << i;
    }
  }
  // HLG: achromatic 75 % at paper white (BT.2408).
  hdrd::Image grey(1, 1);
  grey.rgba = {1, 1, 1, 1};
  write_input(tmp / "grey.exr", grey);
  ASSERT_EQ(run_command(hdrd() + " encode " + (tmp / "grey.exr").string() + " -o " + (tmp / "g").string() +
                        " --tonemap clip --format raw -q --mode hlg")
                .exit_code,
            0);
  raw = slurp(tmp / "g.raw");
  EXPECT_NEAR(static_cast<double>(word_at(raw, 0) & 1023), 0.75 * 1023, 1.5);
}

TEST(EncodeCli, Rec709AndXyzFixturesEncodeAlike) {
  HDRD_REQUIRE_FIXTURE(rec709, "fixtures/exr/Rec709.exr");
  HDRD_REQUIRE_FIXTURE(xyz, "fixtures/exr/XYZ.exr");
  TempDir tmp;
  for (const char* mode : {"hdr10", "sdr"}) {
    const std::string opts = std::string(" --format raw -q --mode ") + mode;
    ASSERT_EQ(run_command(hdrd() + " encode " + rec709.string() + " -o " + (tmp / "a").string() + opts).exit_code, 0);
    ASSERT_EQ(run_command(hdrd() + " encode " + xyz.string() + " -o " + (tmp / "b").string() + opts).exit_code, 0);
    const auto a = slurp(tmp / "a.raw"), b = slurp(tmp / "b.raw");
    ASSERT_EQ(a.size(), b.size());
    int worst = 0;
    for (std::size_t i = 0; i < a.size(); i += 4) {
      const std::uint32_t wa = word_at(a, static_cast<int>(i / 4)), wb = word_at(b, static_cast<int>(i / 4));
      const int bits = std::string(mode) == "hdr10" ? 10 : 8, mask = (1 << bits) - 1;
      for (int c = 0; c < 3; ++c)
        worst = std::max(worst, std::abs(static_cast<int>((wa >> (bits * c)) & mask) -
                                         static_cast<int>((wb >> (bits * c)) & mask)));
    }
    EXPECT_LE(worst, 1) << mode;
  }
}

TEST(EncodeCli, EveryFixtureEncodesToEveryMode) {
  const auto dir = hdrd::testing::fixture("fixtures/exr");
  if (!dir) GTEST_SKIP() << "shared fixtures missing";
  TempDir tmp;
  for (const auto& e : fs::directory_iterator(*dir)) {
    if (e.path().extension() != ".exr") continue;
    for (const char* mode : {"hdr10", "scrgb", "sdr", "sdr-bt1886", "hlg"}) {
      const auto r = run_command(hdrd() + " encode " + e.path().string() + " -o " + (tmp / "o").string() +
                                 " --json -q --mode " + mode);
      ASSERT_EQ(r.exit_code, 0) << e.path() << " " << mode << ": " << r.err;
      const auto j = nlohmann::json::parse(r.out);
      EXPECT_EQ(j["mode"], mode);
      if (std::string(mode) != "scrgb") {
        EXPECT_TRUE(fs::exists(tmp / "o.png"));
      }
      fs::remove_all(tmp.path() / "o.png");
    }
  }
}

struct BadCase {
  const char* name;
  std::string args;
  const char* expect;  // a fragment of the one-line error
};

TEST(EncodeCli, BadInputGetsOneClearLineAndNoFiles) {
  TempDir tmp;
  const fs::path good = tmp / "good.exr";
  write_input(good, held_out_colours(4, 1));
  {
    std::ofstream(tmp / "not.exr") << "this is not an OpenEXR file";
    const auto bytes = hdrd::testing::read_file(good);
    std::ofstream(tmp / "trunc.exr", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  const std::string out = " -o " + (tmp / "out" / "x").string();
  fs::create_directories(tmp / "out");
  const BadCase cases[] = {
      {"missing", (tmp / "nope.exr").string() + out, "nope.exr"},
      {"not exr", (tmp / "not.exr").string() + out, "not.exr"},
      {"truncated", (tmp / "trunc.exr").string() + out, "trunc.exr"},
      {"mode", good.string() + out + " --mode hdr11", "--mode"},
      {"peak", good.string() + out + " --peak -3", "peak"},
      {"curve", good.string() + out + " --tonemap nope", "nope"},
      {"param", good.string() + out + " --tonemap hable --tonemap-param white=-1", "white"},
      {"param syntax", good.string() + out + " --tonemap-param white", "NAME=VALUE"},
      {"format", good.string() + out + " --format gif", "gif"},
      {"scrgb png", good.string() + out + " --mode scrgb --format png", "PNG"},
      {"bits", good.string() + out + " --mode hdr10 --bits 8", "bits"},
      {"ui", good.string() + out + " --ui " + (tmp / "none.png").string(), "none.png"},
      {"exposure", good.string() + out + " --exposure-mode light", "illuminance"},
      {"range", good.string() + out + " --range medium", "range"},
  };
  for (const auto& c : cases) {
    const auto r = run_command(hdrd() + " encode " + c.args);
    EXPECT_NE(r.exit_code, 0) << c.name;
    EXPECT_TRUE(r.out.empty()) << c.name << ": " << r.out;
    // One line, starting with "hdrd: error:", naming the problem.
    EXPECT_EQ(r.err.rfind("hdrd: error: ", 0), 0u) << c.name << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.name << ": " << r.err;
    EXPECT_NE(r.err.find(c.expect), std::string::npos) << c.name << ": " << r.err;
    EXPECT_TRUE(fs::is_empty(tmp / "out")) << c.name << " left files behind";
  }
}

// Issue 29 item 14: `selftest --mode` said "sdr-srgb (or sdr)" where every other --mode says
// sdr: its help lists the display modes as display.mode does, and the alias still works.
TEST(EncodeCli, SelftestModeHelpUsesTheModesVocabulary) {
  const auto h = run_command(hdrd() + " selftest --help");
  ASSERT_EQ(h.exit_code, 0);
  const auto at = h.out.find("--mode");
  ASSERT_NE(at, std::string::npos) << h.out;
  const std::string line = h.out.substr(at, h.out.find('\n', at) - at);
  EXPECT_NE(line.find("hdr10, hlg, scrgb, sdr, sdr-bt1886"), std::string::npos) << line;
  EXPECT_EQ(h.out.find("sdr-srgb"), std::string::npos) << h.out;
  // --no-* flags of render say what they turn off (settings_cli_test checks every one).
  const auto r = run_command(hdrd() + " render --help");
  const auto nl = r.out.find("--no-energy-compensation");
  ASSERT_NE(nl, std::string::npos);
  EXPECT_NE(r.out.substr(nl, 120).find("Turn off energy_compensation"), std::string::npos) << r.out.substr(nl, 200);
  // --environment under its own heading, not "Output:".
  const auto env = r.out.find("--environment ");
  const auto env_head = r.out.rfind("\nEnvironment:", env), out_head = r.out.rfind("\nOutput:", env);
  ASSERT_NE(env_head, std::string::npos) << r.out;
  EXPECT_TRUE(out_head == std::string::npos || out_head < env_head) << r.out;
}

TEST(EncodeCli, HelpHasExamplesAndTonemapListsTheRegistry) {
  const auto r = run_command(hdrd() + " encode --help");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("Examples:"), std::string::npos);
  const auto l = run_command(hdrd() + " tonemap --list --json");
  ASSERT_EQ(l.exit_code, 0);
  const auto j = nlohmann::json::parse(l.out);
  EXPECT_GE(j.size(), 15u);
}


// docs/dump-format.md §5's key table and the keys a real sidecar holds agree both ways
// (`sdr_content_eotf` was written but not documented). The sidecars: hdr10 and hlg (whose
// `hlg_system_gamma` only it has) and sdr, from `hdrd encode`.
std::set<std::string> documented_sidecar_keys() {
  const std::string doc = hdrd::testing::read_file(hdrd::testing::source_dir() / "docs/dump-format.md");
  const auto section = doc.find("## 5. The JSON sidecar");
  EXPECT_NE(section, std::string::npos);
  const auto table = doc.find("| key | type | meaning |", section);
  EXPECT_NE(table, std::string::npos);
  std::set<std::string> keys;
  std::istringstream lines(doc.substr(table));
  std::string line;
  std::getline(lines, line);  // header
  std::getline(lines, line);  // |---|
  while (std::getline(lines, line) && line.starts_with("|")) {
    const std::string cell = line.substr(1, line.find('|', 1) - 1);
    for (std::size_t a = cell.find('`'); a != std::string::npos; a = cell.find('`', a + 1)) {
      const std::size_t b = cell.find('`', a + 1);
      if (b == std::string::npos) break;
      keys.insert(cell.substr(a + 1, b - a - 1));
      a = b;
    }
  }
  return keys;
}

TEST(EncodeCli, DumpFormatKeyTableMatchesTheSidecar) {
  TempDir tmp;
  write_input(tmp / "in.exr", held_out_colours(16, 3));
  std::set<std::string> written;
  for (const char* mode : {"hdr10", "hlg", "sdr"}) {
    const auto r = run_command(hdrd() + " encode " + (tmp / "in.exr").string() + " -o " + (tmp / mode).string() +
                               " --format raw -q --mode " + mode);
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const auto j = nlohmann::json::parse(hdrd::testing::read_file(tmp / (std::string(mode) + ".json")));
    for (const auto& item : j.items()) written.insert(item.key());
  }
  const std::set<std::string> documented = documented_sidecar_keys();
  // Documented as present only in some builds.
  const std::set<std::string> conditional = {"hdrd_version"};
  for (const auto& k : written) EXPECT_TRUE(documented.count(k)) << "sidecar key '" << k << "' is not in docs/dump-format.md §5";
  for (const auto& k : documented)
    EXPECT_TRUE(written.count(k) || conditional.count(k)) << "docs/dump-format.md §5 names '" << k << "', which no sidecar has";
}

// Issue 29 item 12: `hdrd encode` of BrightRingsNanInf.exr counts its non-finite samples
// (OpenImageIO's counts in the fixtures' reference_stats.json: per channel 2 NaN and 4 Inf),
// warns (the summary's notes) and records them in the sidecar; a clean file records zeros, no warning.
TEST(EncodeCli, NonFiniteInputSamplesAreCountedAndWarned) {
  HDRD_REQUIRE_FIXTURE(exr, "fixtures/exr/BrightRingsNanInf.exr");
  HDRD_REQUIRE_FIXTURE(stats_file, "fixtures/exr/reference_stats.json");
  std::uint64_t nan = 0, inf = 0;
  const auto stats = nlohmann::json::parse(hdrd::testing::read_file(stats_file));
  for (const auto& img : stats["images"])
    if (img["file"] == "exr/BrightRingsNanInf.exr")
      for (int c = 0; c < 3; ++c) nan += img["stats_nancount"][c].get<std::uint64_t>(), inf += img["stats_infcount"][c].get<std::uint64_t>();
  ASSERT_GT(nan + inf, 0u);
  TempDir tmp;
  const auto r = run_command(hdrd() + " encode " + exr.string() + " -o " + (tmp / "o").string() + " --format raw");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  const std::string want = fmt::format("input has {} non-finite R, G, B samples ({} NaN, {} infinite)", nan + inf, nan, inf);
  EXPECT_NE((r.out + r.err).find(want), std::string::npos) << r.out << r.err;  // the summary's notes
  const auto j = nlohmann::json::parse(hdrd::testing::read_file(tmp / "o.json"));
  EXPECT_EQ(j["settings"]["input"]["non_finite_samples"], (nlohmann::json{{"nan", nan}, {"inf", inf}}));
  bool warned = false;
  for (const auto& w : j["warnings"]) warned |= w.get<std::string>().find(want) != std::string::npos;
  EXPECT_TRUE(warned);

  write_input(tmp / "clean.exr", held_out_colours(8, 5));
  const auto c = run_command(hdrd() + " encode " + (tmp / "clean.exr").string() + " -o " + (tmp / "c").string() + " --format raw");
  ASSERT_EQ(c.exit_code, 0) << c.err;
  EXPECT_EQ((c.out + c.err).find("non-finite"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(hdrd::testing::read_file(tmp / "c.json"))["settings"]["input"]["non_finite_samples"],
            (nlohmann::json{{"nan", 0}, {"inf", 0}}));
}

}  // namespace
