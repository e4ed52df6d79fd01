// Display profiles from every fixture EDID: the mode rule and the luminance fallbacks,
// checked against values recomputed from manifest.json (not from the parser), plus
// applying a profile to a DisplayTarget and overrides from TOML/JSON.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <nlohmann/json.hpp>

#include "display/profile.hpp"
#include "tests/display/edid_builder.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::display {
namespace {

using nlohmann::json;

const json& manifest() {
  static const json m = [] {
    auto p = hdrd::testing::fixture("fixtures/edid/manifest.json");
    return p ? json::parse(hdrd::testing::read_file(*p)) : json();
  }();
  return m;
}

bool has_note(const Profile& p, const std::string& needle) {
  return std::any_of(p.notes.begin(), p.notes.end(), [&](const std::string& n) { return n.find(needle) != std::string::npos; });
}

// The mode rule of the issue, evaluated on the manifest's own fields.
Mode expected_mode(const json& e) {
  const json& h = e["hdr_static_metadata"];
  const bool pq_block = !h.is_null() && h["eotfs"]["st2084_pq"].get<bool>();
  const bool hlg = !h.is_null() && h["eotfs"]["hlg"].get<bool>();
  const bool bt2020 = e["colorimetry_data_block_present"].get<bool>() && e["colorimetry"]["BT2020RGB"].get<bool>();
  bool did_pq = false;
  if (const json& d = e["displayid_display_parameters"]; !d.is_null() && d.contains("colorspace_eotf_combinations"))
    did_pq = d["colorspace_eotf_combinations"][0].get<std::string>().find("BT.2020/SMPTE ST 2084") != std::string::npos;
  if ((pq_block && bt2020) || did_pq) return Mode::hdr10;
  if (hlg && !pq_block) return Mode::hlg;
  return Mode::sdr;
}

TEST(Profile, EveryFixtureFollowsTheModeAndLuminanceRules) {
  if (!manifest().is_object()) GTEST_SKIP() << "shared fixture missing: ../shared/fixtures/edid";
  int hdr = 0;
  for (const json& e : manifest()["edids"]) {
    const std::string file = e["file"].get<std::string>();
    SCOPED_TRACE(file + " (" + e["category"].get<std::string>() + ")");
    auto r = profile_from_edid_file(*hdrd::testing::fixture("fixtures/edid/" + file));
    ASSERT_TRUE(r.ok()) << r.error().message;
    const Profile& p = *r;
    EXPECT_EQ(p.mode, expected_mode(e));
    EXPECT_TRUE(validate_profile(p).ok()) << validate_profile(p).error().message;
    EXPECT_EQ(p.name, e["display_product_name"].get<std::string>());
    EXPECT_FALSE(p.mode_reason.empty());
    // Peak: the block's max luminance exactly when it is a plausible display peak.
    const json& h = e["hdr_static_metadata"];
    const json max = h.is_null() ? json(nullptr) : h["formula_exact"]["max_cd_m2_formula"];
    const bool usable = max.is_number() && h["desired_max_luminance_cv"].get<int>() != 0 &&
                        max.get<double>() >= kMinPlausibleHdrPeakNits && max.get<double>() <= kMaxPqNits;
    if (usable) {
      EXPECT_NEAR(p.peak_nits, max.get<double>(), 1e-9);
    } else if (p.is_hdr() && e["displayid_display_parameters"].is_null()) {
      // The fallbacks of the panel class (Profile.UnusableMaxFallsBackToWhatThePanelImplies).
      EXPECT_TRUE(p.peak_nits == kFallbackHdrPeakNits || p.peak_nits == kFallbackBt709MonitorPeakNits) << p.peak_nits;
      EXPECT_TRUE(has_note(p, "no usable max luminance")) << p.notes.size();
    }
    EXPECT_LE(p.frame_average_nits, p.peak_nits);
    EXPECT_LT(p.black_nits, p.peak_nits);
    // Primaries are the base block's raw / 1024.
    EXPECT_DOUBLE_EQ(p.primaries.red.x, e["chromaticity"]["exact_raw_div_1024"]["red"][0].get<double>());
    EXPECT_DOUBLE_EQ(p.primaries.white.y, e["chromaticity"]["exact_raw_div_1024"]["white"][1].get<double>());
    hdr += p.is_hdr();
  }
  EXPECT_GT(hdr, 10);
}

// The fixtures the issue names, each with its documented fallback.
const json* by_category(const std::string& category) {
  for (const json& e : manifest()["edids"])
    if (e["category"] == category) return &e;
  return nullptr;
}

Profile profile_of_category(const std::string& category) {
  const json* e = by_category(category);
  if (!e) throw std::runtime_error("no fixture with category " + category);
  return profile_from_edid_file(*hdrd::testing::fixture("fixtures/edid/" + (*e)["file"].get<std::string>())).value();
}

TEST(Profile, AbsurdMaxLuminanceFallsBack) {
  if (!manifest().is_object()) GTEST_SKIP() << "shared fixture missing";
  // DELL U2718Q claims 12525.7 cd/m2 (CV 255, frame-average too); a 61 cm monitor with
  // BT.709 primaries (edid-decode: red 0.6396, 0.3300, ...) is DisplayHDR 400 class (the
  // panel is specified at 400 cd/m2), not the 1000 cd/m2 it fell back to.
  const Profile p = profile_of_category("hdr:bogus_max_cv255");
  EXPECT_EQ(p.mode, Mode::hdr10);
  EXPECT_EQ(p.peak_nits, 400.0);
  EXPECT_EQ(p.frame_average_nits, 400.0);  // its frame-average is the same bogus value
  EXPECT_EQ(p.black_nits, 0.0);            // min CV 0 is 0 whatever the max
  EXPECT_TRUE(has_note(p, "12525.722 cd/m2) is not a plausible display peak"));
  EXPECT_TRUE(has_note(p, "no usable max luminance: peak falls back to 400 cd/m2, the VESA DisplayHDR 400 class of a 61 cm"));
}

// Held-out synthetic EDIDs (tests/display/edid_builder.hpp): an HDR10 panel whose block max
// is unusable takes the peak its other fields and its class imply, in this order, and a
// note names the reason.
TEST(Profile, UnusableMaxFallsBackToWhatThePanelImplies) {
  using namespace hdrd::display::testing;
  auto edid = [](std::uint8_t max_cv, std::uint8_t fall_cv, int width_cm, const std::string& name, bool wide) {
    auto b = base_block(1);
    b[21] = static_cast<std::uint8_t>(width_cm);
    b[22] = width_cm ? 34 : 0;
    std::string n = name.substr(0, 13);
    if (n.size() < 13) n += "\n" + std::string(12 - n.size(), ' ');
    std::copy(n.begin(), n.end(), b.begin() + 72 + 5);
    if (wide) {
      const std::uint16_t p3[8] = {696, 328, 271, 707, 154, 61, 320, 337};  // P3-D65 in 1/1024
      set_chromaticity(b, p3);
    }
    const Block hdr = cta_extended(0x06, {0x05, 0x01, max_cv, fall_cv, 0});  // SDR + PQ, type 1
    const Block colorimetry = cta_extended(0x05, {0x80, 0x00});             // BT2020RGB
    return profile_from_edid(assemble({b, cta_block({hdr, colorimetry})})).value();
  };
  // CV 255 max but a plausible frame-average (CV 96: 50 x 2^3 = 400): the peak is at least that.
  const Profile fall = edid(255, 96, 60, "Test Panel", false);
  ASSERT_EQ(fall.mode, Mode::hdr10);
  EXPECT_DOUBLE_EQ(fall.peak_nits, 400.0);
  EXPECT_TRUE(has_note(fall, "from the desired content max frame-average luminance"));
  // Both bogus; the name states a DisplayHDR tier.
  const Profile tier = edid(255, 255, 60, "DisplayHDR600", true);
  EXPECT_EQ(tier.peak_nits, 600.0);
  EXPECT_TRUE(has_note(tier, "VESA DisplayHDR 600 class"));
  EXPECT_EQ(edid(0, 0, 60, "M27 HDR1000", false).peak_nits, 1000.0);
  // A BT.709-class monitor: DisplayHDR 400.
  const Profile monitor = edid(255, 255, 60, "Test Panel", false);
  EXPECT_EQ(monitor.peak_nits, 400.0);
  EXPECT_TRUE(has_note(monitor, "BT.709-class gamut"));
  // A wide-gamut monitor, or a panel of unknown or TV size: hdrd's HDR default.
  EXPECT_EQ(edid(255, 255, 60, "Test Panel", true).peak_nits, 1000.0);
  EXPECT_EQ(edid(255, 255, 0, "Test Panel", false).peak_nits, 1000.0);
  EXPECT_EQ(edid(255, 255, 140, "Test Panel", false).peak_nits, 1000.0);
  EXPECT_TRUE(has_note(edid(255, 255, 140, "Test Panel", false), "falls back to 1000 cd/m2"));
}

TEST(Profile, NoLuminanceBytesFallsBack) {
  if (!manifest().is_object()) GTEST_SKIP() << "shared fixture missing";
  const Profile p = profile_of_category("hdr:no_luminance_bytes_pq_hlg");
  EXPECT_EQ(p.mode, Mode::hdr10);  // PQ wins over HLG when both are there
  EXPECT_EQ(p.peak_nits, 1000.0);
  EXPECT_EQ(p.black_nits, 0.005);  // REFERENCE.md §1.8 hdr10 black
  EXPECT_TRUE(has_note(p, "no luminance bytes"));
}

TEST(Profile, FrameAverageAboveMaxIsClamped) {
  if (!manifest().is_object()) GTEST_SKIP() << "shared fixture missing";
  const Profile p = profile_of_category("hdr:max1100-1700_hlg");  // FALL CV 190 > max CV 162
  EXPECT_NEAR(p.peak_nits, 50.0 * std::exp2(162 / 32.0), 1e-9);
  EXPECT_EQ(p.frame_average_nits, p.peak_nits);
  EXPECT_TRUE(has_note(p, "exceeds the peak"));
}

TEST(Profile, HlgOnlyDisplayGetsHlg) {
  if (!manifest().is_object()) GTEST_SKIP() << "shared fixture missing";
  EXPECT_EQ(profile_of_category("hdr:hlg_without_pq").mode, Mode::hlg);
  EXPECT_EQ(profile_of_category("hdr:block_no_eotf_bits").mode, Mode::sdr);
  EXPECT_EQ(profile_of_category("sdr:bt2020_colorimetry_but_no_hdr_block").mode, Mode::sdr);
}

TEST(Profile, DisplayIdCarriedHdr) {
  if (!manifest().is_object()) GTEST_SKIP() << "shared fixture missing";
  const Profile p = profile_of_category("hdr:displayid_embedded_cta_1600");
  EXPECT_EQ(p.mode, Mode::hdr10);
  EXPECT_DOUBLE_EQ(p.peak_nits, 1600.0);
  EXPECT_NEAR(p.frame_average_nits, 50.0 * std::exp2(122 / 32.0), 1e-9);
  // No BT2020RGB in its CTA Colorimetry block, but DisplayID 2.0 signals BT.2020/ST 2084.
  const Profile v = profile_of_category("hdr:displayid_embedded_cta_1000");
  EXPECT_EQ(v.mode, Mode::hdr10);
  EXPECT_NE(v.mode_reason.find("DisplayID"), std::string::npos);
  // SDR-only EOTF in DisplayID-carried CTA: SDR, with the panel's real luminance.
  const Profile a = profile_of_category("hdr:displayid_block_sdr_eotf_only");
  EXPECT_EQ(a.mode, Mode::sdr);
  EXPECT_NEAR(a.peak_nits, 50.0 * std::exp2(83 / 32.0), 1e-9);
}

TEST(Profile, MissingEverythingGivesSdrDefaults) {
  using namespace hdrd::display::testing;
  auto b = base_block(0);
  for (int i = 0x19; i <= 0x22; ++i) b[i] = 0;  // no chromaticities
  const Profile p = profile_from_edid(assemble({b})).value();
  EXPECT_EQ(p.mode, Mode::sdr);
  EXPECT_EQ(p.peak_nits, 100.0);
  EXPECT_DOUBLE_EQ(p.black_nits, 0.1);
  EXPECT_EQ(p.primaries, color::kRec709);
  EXPECT_TRUE(has_note(p, "Rec.709"));
  EXPECT_EQ(p.source, "edid:Test Panel");
}

TEST(Profile, ProfileFromBadEdidIsAnError) {
  const std::vector<std::uint8_t> junk(200, 0x42);
  auto r = profile_from_edid(junk);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "edid.bad_header");
  auto f = profile_from_edid_file("/nonexistent/edid.bin");
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("/nonexistent/edid.bin"), std::string::npos);
}

Profile hdr_profile() {
  Profile p;
  p.mode = Mode::hdr10;
  p.peak_nits = 600;
  p.frame_average_nits = 400;
  p.black_nits = 0.05;
  p.primaries = color::kDisplayP3;
  p.name = "Panel";
  p.source = "edid:Panel";
  return p;
}

TEST(ProfileLevels, SetLevelsPrimariesAndSourceOfAnyMode) {
  // The resolver keeps the mode asked for and takes the display's levels.
  auto t = resolve_target(Mode::hlg, profile_levels(hdr_profile()), {}, "edid:Panel");
  ASSERT_TRUE(t.ok()) << t.error().message;
  EXPECT_EQ(t->mode, Mode::hlg);
  EXPECT_EQ(t->peak_nits, 600);
  EXPECT_EQ(t->black_nits, 0.05);
  ASSERT_TRUE(t->display_primaries);
  EXPECT_EQ(*t->display_primaries, color::kDisplayP3);
  EXPECT_EQ(t->source, "edid:Panel");
  EXPECT_EQ(t->paper_white_nits, 203);
  const DisplayTarget u = target_for_profile(hdr_profile());
  EXPECT_EQ(u.mode, Mode::hdr10);
  EXPECT_TRUE(validate(u).ok());
  // The mastering metadata the encoder writes follows the profile.
  EXPECT_EQ(u.mastering().max_nits, 600);
  EXPECT_EQ(u.mastering().primaries, color::kDisplayP3);
}

TEST(ProfileLevels, SdrTargetsKeepPaperWhiteAtThePeak) {
  Profile p = hdr_profile();
  p.mode = Mode::sdr;
  p.peak_nits = 300;
  p.black_nits = 0.3;
  const DisplayTarget t = target_for_profile(p);
  EXPECT_EQ(t.mode, Mode::sdr);
  EXPECT_EQ(t.bits, 8);
  EXPECT_EQ(t.peak_nits, 300);
  EXPECT_EQ(t.paper_white_nits, 300);
  EXPECT_EQ(t.ui_white_nits, 300);
  EXPECT_TRUE(validate(t).ok());
  // A user's own SDR paper white is left alone, and the source says the request set it.
  LevelSettings req;
  req.paper_white_nits = 80;
  auto u = resolve_target(Mode::sdr, profile_levels(p), req, p.source);
  ASSERT_TRUE(u.ok());
  EXPECT_EQ(u->paper_white_nits, 80);
  EXPECT_EQ(u->ui_white_nits, 80);
  EXPECT_EQ(u->source, "edid:Panel+request");
}

TEST(ProfileOverride, TomlExampleFromConfigMatchesAndApplies) {
  auto o = load_profile_override(hdrd::testing::source_dir() / "config/profiles/dell-u2718q.toml");
  ASSERT_TRUE(o.ok()) << o.error().message;
  EXPECT_EQ(o->match_manufacturer, "DEL");
  EXPECT_EQ(o->match_product_code, 41194);
  Profile p = hdr_profile();
  EXPECT_FALSE(o->matches(p));
  p.manufacturer = "DEL";
  p.product_code = 0xA0EA;
  EXPECT_TRUE(o->matches(p));
  auto r = apply_matching_overrides(p, {*o});
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->peak_nits, 400);
  EXPECT_EQ(r->frame_average_nits, 350);
  EXPECT_EQ(r->black_nits, 0.3);
  EXPECT_TRUE(has_note(*r, "dell-u2718q.toml"));
  EXPECT_NE(r->source.find("+override:"), std::string::npos);
}

TEST(ProfileOverride, EveryConfigExampleParses) {
  auto all = load_profile_overrides(hdrd::testing::source_dir() / "config/profiles");
  ASSERT_TRUE(all.ok()) << all.error().message;
  EXPECT_EQ(all->size(), 3u);
  auto json_one = load_profile_override(hdrd::testing::source_dir() / "config/profiles/lg-tv-no-luminance.json");
  ASSERT_TRUE(json_one.ok()) << json_one.error().message;
  EXPECT_EQ(json_one->match_product_code, 0x82CD);
  EXPECT_EQ(json_one->primaries, color::kDisplayP3);
}

TEST(ProfileOverride, RequestOverridesAreFlatJson) {
  auto o = parse_profile_override(json{{"mode", "hlg"}, {"peak_nits", 800}}, "request");
  ASSERT_TRUE(o.ok()) << o.error().message;
  auto r = apply_override(hdr_profile(), *o);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->mode, Mode::hlg);
  EXPECT_EQ(r->peak_nits, 800);
  EXPECT_EQ(r->mode_reason, "set by override request");
}

TEST(ProfileOverride, ErrorsNameTheFieldAndSource) {
  auto bad_key = parse_profile_override(json{{"peak", 800}}, "request");
  ASSERT_FALSE(bad_key.ok());
  EXPECT_EQ(bad_key.error().message, "request: unknown or mistyped profile key 'peak'");
  auto bad_mode = parse_profile_override(json{{"mode", "hdr11"}}, "x.json");
  ASSERT_FALSE(bad_mode.ok());
  EXPECT_EQ(bad_mode.error().field, "mode");
  auto toml = parse_profile_override_toml("[profile]\npeak_nits = = 3\n", "bad.toml");
  ASSERT_FALSE(toml.ok());
  EXPECT_NE(toml.error().message.find("bad.toml: TOML syntax error at line 2"), std::string::npos);
  auto black = apply_override(hdr_profile(), *parse_profile_override(json{{"black_nits", 700}}, "request"));
  ASSERT_FALSE(black.ok());
  EXPECT_EQ(black.error().field, "black_nits");
  EXPECT_NE(black.error().message.find("(after override request)"), std::string::npos);
  auto prim = parse_profile_override(json{{"primaries", {{"red", {0.7, 0.3}}}}}, "request");
  ASSERT_FALSE(prim.ok());
  EXPECT_EQ(prim.error().message, "request: primaries.green is missing");
}

TEST(ProfileOverride, WithoutMatchIsNotAppliedFromADirectory) {
  auto o = parse_profile_override(json{{"profile", {{"peak_nits", 123}}}}, "any.json");
  ASSERT_TRUE(o.ok());
  auto r = apply_matching_overrides(hdr_profile(), {*o});
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->peak_nits, 600);
}

}  // namespace
}  // namespace hdrd::display
