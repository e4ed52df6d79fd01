// The fast path's tone tables (ToneStage: per-channel offset-ratio, ratio of max(RGB), the
// black lift) against the curve itself, for every registered scalar curve, at several
// displays and parameter sets: within one 16-bit PQ step at and around every kink the
// numeric finder sees (tonemap::find_kinks, not the curve's own list) and on a sweep over
// the range, and black exactly the curve's black. BT.2390's corner (display peak at or
// above the source peak) used to come out 11 steps low at 1000 cd/m2.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "encode/colour/transfer.hpp"
#include "encode/kernel/pipeline_internal.hpp"
#include "encode/pipeline.hpp"
#include "encode/tone/tonemap.hpp"

using namespace hdrd;

namespace {

struct TableCase {
  std::string curve;
  double peak, paper_white;
  tonemap::ParamValues params;
  tonemap::Apply apply;
  std::string label;
};

PreparedPipeline prepared(const TableCase& c, Image& img) {
  EncodeSettings s;
  s.target = default_target(Mode::hdr10);
  s.target.peak_nits = c.peak;
  s.target.paper_white_nits = c.paper_white;
  s.target.black_nits = 0.005;
  s.tone.curve = c.curve;
  s.tone.params = c.params;
  s.tone.apply = c.apply;
  SceneInput in;
  in.image = &img;
  auto p = prepare_pipeline(in, s);
  EXPECT_TRUE(p.ok()) << (p.ok() ? "" : p.error().message);
  return std::move(p).value();
}

// The stage's light for a grey relative input x (what the kernels compute per channel).
double table_nits(const detail::ToneStage& t, float x) {
  if (t.kind == detail::ToneKind::per_channel) return detail::toe_lookup(t.lut, t.zero_nits, t.toe_slope, x);
  float n = x > 0 ? x * t.lut(x) : 0.0f;
  if (x >= t.lut.hi()) n = x * t.lut(t.lut.hi()) * (t.lut.hi() / x);
  if (t.has_lift) n = detail::toe_lookup(t.lift, t.lift_zero_nits, t.lift_toe_slope, n);
  return n;
}

double pq_steps(double a_nits, double b_nits) {
  return std::abs(transfer::pq_inverse_eotf(a_nits) - transfer::pq_inverse_eotf(b_nits)) * 65535;
}

class ToneTables : public ::testing::TestWithParam<TableCase> {};

TEST_P(ToneTables, WithinOneSixteenBitStepAtAndAroundEveryKink) {
  const TableCase& c = GetParam();
  Image img(1, 1);
  const PreparedPipeline p = prepared(c, img);
  const auto stage = detail::build_tone_stage(p);
  ASSERT_TRUE(stage.kind == detail::ToneKind::per_channel || stage.kind == detail::ToneKind::ratio);
  const double pw = c.paper_white;
  auto want = [&](double x) { return p.curve->map(x) * pw; };  // grey: shape then lift = map
  double worst = 0, worst_x = 0;
  auto check = [&](float x) {
    const double d = pq_steps(table_nits(stage, x), want(x));
    if (d > worst) worst = d, worst_x = x;
  };
  const auto kinks = tonemap::find_kinks(want, 1e-5, 1e5);
  for (double k : kinks) {
    // The kink's bucket and the ones either side (each is 1/128 octave, 0.54 %), densely.
    for (int j = -2000; j <= 2000; ++j) check(static_cast<float>(k * (1 + 4e-6 * j)));
    check(static_cast<float>(k));
    check(std::nextafter(static_cast<float>(k), 0.0f));
    check(std::nextafter(static_cast<float>(k), 1e30f));
  }
  for (double lg = -5; lg <= 5; lg += 1.0 / 512) check(static_cast<float>(std::pow(10.0, lg)));
  EXPECT_LE(worst, 1.0) << "worst at x = " << worst_x << " (kinks found: " << kinks.size() << ")";
  // Black is the curve's black exactly (0, or the display black with BT.2390's lift).
  EXPECT_NEAR(table_nits(stage, 0.0f), want(0.0), 1e-6 * std::max(1.0, want(0.0)));
}

std::vector<TableCase> table_cases() {
  std::vector<TableCase> v;
  const std::pair<double, double> displays[] = {{100, 100}, {400, 203}, {1000, 203}, {4000, 203}, {10000, 203}};
  for (const auto& info : tonemap::curves()) {
    if (!info.scalar) continue;
    for (const auto& [peak, pw] : displays)
      for (auto apply : {tonemap::Apply::per_channel, tonemap::Apply::max_rgb}) {
        if (std::string(info.name) == "clip" && apply == tonemap::Apply::per_channel) continue;  // exact, no table
        v.push_back({std::string(info.name), peak, pw, {}, apply,
                     std::string(info.name) + "_" + std::to_string(int(peak)) + "_" + std::string(tonemap::to_string(apply))});
      }
  }
  // BT.2390 around its corners: source peak at, below and above the display's; a source
  // black; the black lift on.
  for (double src : {400.0, 1000.0, 4000.0})
    for (double lift : {0.0, 1.0})
      for (double src_black : {0.0, 0.05})
        for (double peak : {600.0, 1000.0, 4000.0})
          v.push_back({"bt2390", peak, 203,
                       {{"source_peak_nits", src}, {"black_lift", lift}, {"source_black_nits", src_black}},
                       tonemap::Apply::max_rgb,
                       "bt2390_src" + std::to_string(int(src)) + "_lift" + std::to_string(int(lift)) + "_black" +
                           std::to_string(int(src_black * 100)) + "_" + std::to_string(int(peak))});
  v.push_back({"reinhard-extended", 1000, 203, {{"white", 2.5}}, tonemap::Apply::max_rgb, "reinhard_extended_white2_5"});
  v.push_back({"day", 1000, 203, {{"black", 0.01}}, tonemap::Apply::per_channel, "day_black0_01"});
  v.push_back({"hable", 1000, 203, {{"exposure_bias", 2.0}}, tonemap::Apply::per_channel, "hable_bias2"});
  return v;
}

INSTANTIATE_TEST_SUITE_P(Registry, ToneTables, ::testing::ValuesIn(table_cases()), [](const auto& info) {
  std::string n = info.param.label;
  for (char& ch : n)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return n;
});

}  // namespace
