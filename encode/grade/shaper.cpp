// Shapers: scene-referred values into a 3D LUT's [0,1] input (RTR4 §8.2.3: "a shaper
// such as PQ, a log curve or one or two square roots" spends the lattice where the eye
// needs it instead of linearly). Each has an exact inverse on its covered range.
#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <cmath>

#include "encode/grade/lut.hpp"
#include "encode/colour/transfer.hpp"

namespace hdrd::lut {

namespace {
constexpr double kMidGrey = 0.18;
constexpr const char* kShaperTag = "HDRD_SHAPER ";

double clamp01(double s) { return s > 0 ? std::min(s, 1.0) : 0.0; }  // NaN -> 0
double signed_pow(double s, double p) { return s >= 0 ? std::pow(s, p) : -std::pow(-s, p); }
}  // namespace

ShaperSpec ShaperSpec::defaults(grade::Shaper kind) {
  switch (kind) {
    case grade::Shaper::log2: return {kind, -12.0, 9.0};
    case grade::Shaper::none: return {kind, 0.0, 1.0};
    default: return {kind, 0.0, 100.0};
  }
}

double shape(const ShaperSpec& s, double x) {
  if (!(x > 0)) x = 0;
  switch (s.kind) {
    case grade::Shaper::pq:  // max is the input value that maps to 10000 cd/m2 (PQ 1.0)
      return transfer::pq_inverse_eotf(std::min(x / s.max, 1.0) * transfer::kPqPeakNits);
    case grade::Shaper::log2: {
      const double x0 = kMidGrey * std::exp2(s.min);
      return clamp01((std::log2((x + x0) / kMidGrey) - s.min) / (s.max - s.min));
    }
    case grade::Shaper::sqrt: return clamp01(std::sqrt(x / s.max));
    case grade::Shaper::sqrt_sqrt: return clamp01(std::sqrt(std::sqrt(x / s.max)));
    case grade::Shaper::none: return x;
  }
  return x;
}

// The inverse extends past [0,1] where the formula allows (a look may push a value
// above the lattice's top), so LUT outputs slightly outside [0,1] are not clipped.
double unshape(const ShaperSpec& s, double v) {
  if (std::isnan(v)) return 0;
  switch (s.kind) {
    case grade::Shaper::pq: return transfer::pq_eotf(v) / transfer::kPqPeakNits * s.max;
    case grade::Shaper::log2: {
      const double x0 = kMidGrey * std::exp2(s.min);
      return kMidGrey * std::exp2(s.min + v * (s.max - s.min)) - x0;
    }
    case grade::Shaper::sqrt: return signed_pow(v, 2.0) * s.max;
    case grade::Shaper::sqrt_sqrt: return signed_pow(v, 4.0) * s.max;
    case grade::Shaper::none: return v;
  }
  return v;
}

std::string to_string(const ShaperSpec& s) {
  const auto d = ShaperSpec::defaults(s.kind);
  const std::string name(grade::to_string(s.kind));
  if (s == d || s.kind == grade::Shaper::none) return name;
  if (s.kind == grade::Shaper::log2) return fmt::format("{}:{}:{}", name, s.min, s.max);
  return fmt::format("{}:{}", name, s.max);
}

Result<ShaperSpec> parse_shaper_spec(std::string_view text) {
  const auto bad = [&](std::string why) {
    return make_error("grade.shaper", fmt::format("shaper '{}': {} (pq, pq:MAX, log2, log2:LO:HI, sqrt, sqrt:MAX, "
                                                  "sqrt-sqrt, sqrt-sqrt:MAX, none)", text, why),
                      "lut_shaper");
  };
  std::vector<std::string_view> parts;
  for (std::size_t pos = 0;;) {
    const std::size_t c = text.find(':', pos);
    parts.push_back(text.substr(pos, c == std::string_view::npos ? std::string_view::npos : c - pos));
    if (c == std::string_view::npos) break;
    pos = c + 1;
  }
  const auto kind = grade::parse_shaper(parts[0]);
  if (!kind) return bad("unknown shaper");
  ShaperSpec s = ShaperSpec::defaults(*kind);
  std::vector<double> nums;
  for (std::size_t i = 1; i < parts.size(); ++i) {
    double v = 0;
    const auto [p, ec] = std::from_chars(parts[i].data(), parts[i].data() + parts[i].size(), v);
    if (ec != std::errc() || p != parts[i].data() + parts[i].size() || !std::isfinite(v))
      return bad(fmt::format("'{}' is not a number", parts[i]));
    nums.push_back(v);
  }
  if (*kind == grade::Shaper::none && !nums.empty()) return bad("takes no parameters");
  if (*kind == grade::Shaper::log2) {
    if (nums.size() == 1 || nums.size() > 2) return bad("log2 takes LO:HI stops around mid grey");
    if (nums.size() == 2) {
      if (!(nums[0] < nums[1]) || nums[1] - nums[0] > 64 || std::fabs(nums[0]) > 64 || std::fabs(nums[1]) > 64)
        return bad("needs LO < HI, both within +-64 stops");
      s.min = nums[0];
      s.max = nums[1];
    }
  } else if (!nums.empty()) {
    if (nums.size() != 1) return bad("takes one parameter, MAX");
    if (!(nums[0] > 0) || nums[0] > 1e9) return bad("MAX must be positive");
    s.max = nums[0];
  }
  return s;
}

std::string shaper_comment(const ShaperSpec& s) { return kShaperTag + to_string(s); }

std::optional<ShaperSpec> shaper_from_comments(const std::vector<std::string>& comments) {
  for (const auto& c : comments) {
    if (c.rfind(kShaperTag, 0) != 0) continue;
    auto s = parse_shaper_spec(std::string_view(c).substr(std::string_view(kShaperTag).size()));
    if (s) return *s;
  }
  return std::nullopt;
}

}  // namespace hdrd::lut

// ---- Buffer shaper ---------------------------------------------------------------------
namespace hdrd::lut {

namespace {
constexpr int kMantissaBits = 23;

std::uint32_t bits_of(float f) {
  std::uint32_t b;
  std::memcpy(&b, &f, sizeof b);
  return b;
}
float float_of(std::uint32_t b) {
  float f;
  std::memcpy(&f, &b, sizeof f);
  return f;
}

// Segments linear in u, 2^steps_log2 per octave: a float's top mantissa bits index them,
// so no log2 is needed per value (the classic exponent/mantissa table trick).
template <class F>
void build(auto& t, int low_exp, int steps_log2, F&& f) {
  t.low_exp = low_exp;
  t.steps_log2 = steps_log2;
  const int shift = kMantissaBits - steps_log2;
  t.lowest = std::ldexp(1.0f, low_exp);
  t.first_key = bits_of(t.lowest) >> shift;
  const std::uint32_t last_key = bits_of(1.0f) >> shift;
  t.values.resize(last_key - t.first_key + 2);
  for (std::uint32_t k = t.first_key; k <= last_key + 1; ++k)
    t.values[k - t.first_key] = static_cast<float>(f(double(float_of(k << shift))));
  t.at_zero = static_cast<float>(f(0.0));
}
}  // namespace

detail::BitTableArgs ShaperTable::BitTable::args(float scale, float at_one) const {
  return {values.data(), static_cast<std::uint32_t>(values.size()), first_key, kMantissaBits - steps_log2,
          lowest, at_zero, at_one, scale};
}

float ShaperTable::BitTable::eval(float u, float at_one) const {
  if (!(u > lowest)) return u > 0 ? at_zero + (values[0] - at_zero) * (u / lowest) : at_zero;
  if (u >= 1.0f) return at_one;
  const int shift = kMantissaBits - steps_log2;
  const std::uint32_t b = bits_of(u);
  const std::uint32_t i = (b >> shift) - first_key;
  const float frac = float(b & ((1u << shift) - 1)) * (1.0f / float(1u << shift));
  return values[i] + (values[i + 1] - values[i]) * frac;
}

ShaperTable::ShaperTable(const ShaperSpec& spec) : spec_(spec) {
  if (spec.kind != grade::Shaper::pq) return;
  // Forward on u = x / max down to 2^-60 (PQ there is 3e-7 above PQ(0), so the linear
  // piece below it stays within the error budget); inverse on the signal down to 2^-21,
  // below PQ(0) = 7.3e-7 where the EOTF is 0.
  build(fwd_, -60, 9, [&](double u) { return transfer::pq_inverse_eotf(u * transfer::kPqPeakNits); });
  build(inv_, -21, 10, [&](double s) { return transfer::pq_eotf(s) / transfer::kPqPeakNits * spec.max; });
}

float ShaperTable::forward(float x) const {
  switch (spec_.kind) {
    case grade::Shaper::pq: return fwd_.eval(x / static_cast<float>(spec_.max), 1.0f);
    case grade::Shaper::none: return x;
    case grade::Shaper::log2: {
      if (!(x > 0)) x = 0;
      const float lo = static_cast<float>(spec_.min), span = static_cast<float>(spec_.max - spec_.min);
      const float x0 = static_cast<float>(kMidGrey) * std::exp2(lo);
      const float s = (std::log2((x + x0) * (1.0f / static_cast<float>(kMidGrey))) - lo) / span;
      return std::clamp(s, 0.0f, 1.0f);
    }
    case grade::Shaper::sqrt:
      return x > 0 ? std::min(std::sqrt(x / static_cast<float>(spec_.max)), 1.0f) : 0.0f;
    case grade::Shaper::sqrt_sqrt:
      return x > 0 ? std::min(std::sqrt(std::sqrt(x / static_cast<float>(spec_.max))), 1.0f) : 0.0f;
  }
  return x;
}

float ShaperTable::inverse(float s) const {
  switch (spec_.kind) {
    case grade::Shaper::pq:
      return s > 1.0f ? static_cast<float>(spec_.max) : inv_.eval(s, static_cast<float>(spec_.max));
    case grade::Shaper::none: return s;
    case grade::Shaper::log2: {
      if (std::isnan(s)) return 0;
      const float lo = static_cast<float>(spec_.min), span = static_cast<float>(spec_.max - spec_.min);
      const float x0 = static_cast<float>(kMidGrey) * std::exp2(lo);
      return static_cast<float>(kMidGrey) * std::exp2(lo + s * span) - x0;
    }
    case grade::Shaper::sqrt: return (s >= 0 ? s * s : -s * s) * static_cast<float>(spec_.max);
    case grade::Shaper::sqrt_sqrt: {
      const float s2 = s * s;
      return (s >= 0 ? s2 * s2 : -s2 * s2) * static_cast<float>(spec_.max);
    }
  }
  return s;
}

// Whole buffers: the PQ case (the display placement's, the common one) gets its own loop
// so nothing but the table lookup runs per value.
void ShaperTable::forward_rgba(float* rgba, std::size_t pixels) const {
  if (spec_.kind == grade::Shaper::none) return;
  if (spec_.kind == grade::Shaper::pq) {
    const float inv_max = static_cast<float>(1.0 / spec_.max);
    return detail::bit_table_rgba(fwd_.args(inv_max, 1.0f), rgba, pixels);
  }
  for (std::size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < 3; ++c) rgba[4 * i + c] = forward(rgba[4 * i + c]);
}

void ShaperTable::inverse_rgba(float* rgba, std::size_t pixels) const {
  if (spec_.kind == grade::Shaper::none) return;
  if (spec_.kind == grade::Shaper::pq)  // s > 1 falls in the table's "at one" branch
    return detail::bit_table_rgba(inv_.args(1.0f, static_cast<float>(spec_.max)), rgba, pixels);
  for (std::size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < 3; ++c) rgba[4 * i + c] = inverse(rgba[4 * i + c]);
}

}  // namespace hdrd::lut
