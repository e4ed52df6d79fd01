// The gain map between the SDR and the HDR rendition of one frame (ISO 21496-1 §5 and the
// Ultra HDR 1.0 "Encode" section, which define the same maths): both renditions in linear
// Rec.709 light relative to SDR white, a log2 ratio with offsets per map pixel, normalised
// between the map's min and max boost and raised to the map gamma.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "encode/colour/transfer.hpp"
#include "encode/grade/lut.hpp"
#include "encode/io/internal.hpp"
#include "encode/io/stills.hpp"
#include "encode/parallel.hpp"

namespace hdrd::io {
namespace {

Error gain_error(std::string code, std::string message, std::string field = {}) {
  return make_error("gainmap." + code, std::move(message), std::move(field));
}

Result<void> check_inputs(const EncodedFrame& sdr, const EncodedFrame& hdr, const GainMapOptions& o) {
  if (hdr.target.mode != Mode::hdr10 && hdr.target.mode != Mode::hlg)
    return gain_error("mode", fmt::format("the HDR rendition must be hdr10 or hlg, not {}", to_string(hdr.target.mode)),
                      "display.mode");
  if (auto ok = detail::check_frame(hdr); !ok) return ok.error();
  if (sdr.width != hdr.width || sdr.height != hdr.height)
    return gain_error("size", fmt::format("the SDR rendition is {}x{} but the HDR rendition {}x{}", sdr.width, sdr.height,
                                          hdr.width, hdr.height));
  if (o.gain_map_scale < 1 || o.gain_map_scale > 16)
    return gain_error("options", fmt::format("gain map scale {} is outside 1..16", o.gain_map_scale), "gainmap.scale");
  if (!(o.gamma > 0 && o.gamma <= 16))
    return gain_error("options", fmt::format("gain map gamma {} is outside (0, 16]", o.gamma), "gainmap.gamma");
  if (!(o.offset_sdr >= 0 && o.offset_sdr <= 1) || !(o.offset_hdr >= 0 && o.offset_hdr <= 1))
    return gain_error("options", "gain map offsets must lie in [0, 1]", "gainmap.offset");
  if (o.offset_sdr == 0 || o.offset_hdr == 0) {
    // log2 of a ratio with a zero term: black pixels would give +-infinity.
    return gain_error("options", "gain map offsets must be > 0 (black pixels have no finite ratio otherwise)",
                      "gainmap.offset");
  }
  return {};
}

// 8-bit sRGB code -> linear light relative to SDR white (IEC 61966-2-1; the SDR frame's
// display light is srgb_eotf(V) * peak, its white its paper white).
std::array<float, 256> sdr_table(const DisplayTarget& t) {
  std::array<float, 256> table{};
  for (int i = 0; i < 256; ++i)
    table[static_cast<std::size_t>(i)] =
        static_cast<float>(transfer::srgb_eotf(i / 255.0) * t.peak_nits / t.paper_white_nits);
  return table;
}

// The HDR frame's display light, Rec.709, relative to its paper white (= SDR white).
class HdrLight {
 public:
  explicit HdrLight(const DisplayTarget& t)
      : hlg_(t.mode == Mode::hlg), peak_(t.peak_nits), gamma_(transfer::hlg_system_gamma(t.peak_nits)),
        table_(65536), to709_(color::rgb_to_rgb(color::kRec2020, color::kRec709)) {
    // Per 16-bit sample (detail::sample16's meaning): PQ -> nits; HLG -> scene light E
    // (the OOTF couples the channels, so it runs per pixel).
    for (std::size_t s = 0; s < table_.size(); ++s) {
      const double e = t.range == Range::full ? s / 65535.0 : (s / 256.0 - 16.0) / 219.0;
      const double signal = std::clamp(e, 0.0, 1.0);
      table_[s] = static_cast<float>(hlg_ ? transfer::hlg_inverse_oetf(signal) : transfer::pq_eotf(signal));
    }
    inv_paper_ = 1.0 / t.paper_white_nits;
  }

  color::Vec3 at(const EncodedFrame& f, int x, int y) const {
    color::Vec3 v{table_[detail::sample16(f, x, y, 0)], table_[detail::sample16(f, x, y, 1)],
                  table_[detail::sample16(f, x, y, 2)]};
    if (hlg_) {  // BT.2100 HLG EOTF: F_D = Lw Ys^(gamma - 1) E
      const double ys = color::dot(color::kRec2020Luma, v);
      v = v * (ys > 0 ? peak_ * std::pow(ys, gamma_ - 1.0) : 0.0);
    }
    const color::Vec3 c = to709_ * v;
    return {std::max(c.x, 0.0) * inv_paper_, std::max(c.y, 0.0) * inv_paper_, std::max(c.z, 0.0) * inv_paper_};
  }

 private:
  bool hlg_;
  double peak_, gamma_, inv_paper_ = 1;
  std::vector<float> table_;
  color::Mat3 to709_;
};

struct LogGains {
  int width = 0, height = 0, channels = 3;
  std::vector<float> log2_gain;  // width x height x channels
};

// log2((hdr + k_hdr) / (sdr + k_sdr)) of the block-averaged linear light of each map pixel.
LogGains log_gains(const EncodedFrame& sdr, std::span<const std::uint8_t> sdr_rgb, const EncodedFrame& hdr,
                   const GainMapOptions& o) {
  const int s = o.gain_map_scale;
  LogGains g;
  g.width = (sdr.width + s - 1) / s;
  g.height = (sdr.height + s - 1) / s;
  g.channels = o.channels == GainMapChannels::rgb ? 3 : 1;
  g.log2_gain.resize(static_cast<std::size_t>(g.width) * g.height * g.channels);
  const auto sdr_lin = sdr_table(sdr.target);
  const HdrLight hdr_light(hdr.target);
  parallel_for(static_cast<std::size_t>(g.height), 0, 4, [&](std::size_t y0, std::size_t y1) {
    for (int my = static_cast<int>(y0); my < static_cast<int>(y1); ++my)
      for (int mx = 0; mx < g.width; ++mx) {
        color::Vec3 sum_sdr, sum_hdr;
        int n = 0;
        for (int y = my * s; y < std::min((my + 1) * s, sdr.height); ++y)
          for (int x = mx * s; x < std::min((mx + 1) * s, sdr.width); ++x, ++n) {
            const std::uint8_t* p = &sdr_rgb[(static_cast<std::size_t>(y) * sdr.width + x) * 3];
            sum_sdr = sum_sdr + color::Vec3{sdr_lin[p[0]], sdr_lin[p[1]], sdr_lin[p[2]]};
            sum_hdr = sum_hdr + hdr_light.at(hdr, x, y);
          }
        const color::Vec3 a = sum_sdr * (1.0 / n), b = sum_hdr * (1.0 / n);
        float* out = &g.log2_gain[(static_cast<std::size_t>(my) * g.width + mx) * g.channels];
        // Float log2: the map resolves (max - min) / 255, ~0.01; float's error is ~1e-7.
        const auto log_ratio = [&](double hdr_v, double sdr_v) {
          return std::log2(static_cast<float>((hdr_v + o.offset_hdr) / (sdr_v + o.offset_sdr)));
        };
        if (g.channels == 1) {
          out[0] = log_ratio(color::dot(color::kRec709Luma, b), color::dot(color::kRec709Luma, a));
          continue;
        }
        for (int c = 0; c < 3; ++c) out[c] = log_ratio(b[c], a[c]);
      }
  });
  return g;
}

// Rounded to what the metadata can say exactly (1e-6: the ISO 21496-1 fractions below), so
// the map is encoded with the very numbers a decoder reads back.
double carried(double v) { return std::round(v * 1e6) / 1e6; }
constexpr double kMinCapacityLog2 = 1e-3;

GainMapMetadata metadata_for(const LogGains& g, const EncodedFrame& hdr, const GainMapOptions& o) {
  GainMapMetadata m;
  m.channels = g.channels;
  m.gamma = carried(o.gamma);
  m.offset_sdr = carried(o.offset_sdr);
  m.offset_hdr = carried(o.offset_hdr);
  m.hdr_capacity_min_log2 = 0;  // the base is the SDR rendition: no headroom needed
  // A peak at or below paper white (which follows a lower peak, or is clipped there: the
  // rule every output shares, encode/display_target.hpp paper_white_note) has no headroom:
  // the HDR rendition is the SDR one, and the capacity range keeps the smallest step the
  // metadata's weight (ISO 21496-1 §5.2.5, a division by max - min) is defined for.
  m.hdr_capacity_max_log2 =
      carried(std::max(std::log2(hdr.target.peak_nits / hdr.target.paper_white_nits), kMinCapacityLog2));
  for (int c = 0; c < g.channels; ++c) {
    float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
    for (std::size_t i = static_cast<std::size_t>(c); i < g.log2_gain.size(); i += static_cast<std::size_t>(g.channels)) {
      lo = std::min(lo, g.log2_gain[i]);
      hi = std::max(hi, g.log2_gain[i]);
    }
    // A flat map still needs max > min for the normalisation to be defined.
    m.gain_map_min_log2[static_cast<std::size_t>(c)] = std::floor(lo * 1e6) / 1e6;
    m.gain_map_max_log2[static_cast<std::size_t>(c)] = std::max(std::ceil(hi * 1e6) / 1e6, m.gain_map_min_log2[static_cast<std::size_t>(c)] + 1e-3);
  }
  return m;
}

}  // namespace

namespace detail {

Result<GainMap> gain_map_of(const EncodedFrame& sdr, std::span<const std::uint8_t> sdr_rgb, const EncodedFrame& hdr,
                            const GainMapOptions& options) {
  if (auto ok = check_inputs(sdr, hdr, options); !ok) return ok.error();
  const LogGains g = log_gains(sdr, sdr_rgb, hdr, options);
  GainMap map;
  map.width = g.width;
  map.height = g.height;
  map.channels = g.channels;
  map.metadata = metadata_for(g, hdr, options);
  map.samples.resize(g.log2_gain.size());
  const GainMapMetadata& m = map.metadata;
  for (std::size_t i = 0; i < g.log2_gain.size(); ++i) {
    const auto c = i % static_cast<std::size_t>(g.channels);
    const double lo = m.gain_map_min_log2[c], hi = m.gain_map_max_log2[c];
    const double t = std::clamp((g.log2_gain[i] - lo) / (hi - lo), 0.0, 1.0);
    map.samples[i] = static_cast<std::uint8_t>((m.gamma == 1.0 ? t : std::pow(t, m.gamma)) * 255.0 + 0.5);  // t >= 0
  }
  return map;
}

}  // namespace detail

Result<GainMap> compute_gain_map(const EncodedFrame& sdr, const EncodedFrame& hdr, const GainMapOptions& options) {
  auto sdr_rgb = detail::sdr_samples(sdr);
  if (!sdr_rgb) return sdr_rgb.error();
  return detail::gain_map_of(sdr, *sdr_rgb, hdr, options);
}

}  // namespace hdrd::io
