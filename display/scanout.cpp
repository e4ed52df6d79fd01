#include "display/scanout.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "display/edid.hpp"
#include "encode/colour/color.hpp"
#include "encode/colour/transfer.hpp"

namespace hdrd::display {
namespace {

std::uint32_t load32(const std::uint8_t* p) {
  return std::uint32_t(p[0]) | (std::uint32_t(p[1]) << 8) | (std::uint32_t(p[2]) << 16) | (std::uint32_t(p[3]) << 24);
}
void store32(std::uint8_t* p, std::uint32_t v) {
  p[0] = v & 0xff;
  p[1] = (v >> 8) & 0xff;
  p[2] = (v >> 16) & 0xff;
  p[3] = (v >> 24) & 0xff;
}

// DRM_FORMAT_XBGR2101010: little-endian 32-bit word, R bits 0-9, G 10-19, B 20-29.
std::uint32_t pack_xbgr2101010(int r, int g, int b) {
  return std::uint32_t(r) | (std::uint32_t(g) << 10) | (std::uint32_t(b) << 20);
}

int narrow_to_full(int code, int bits) {
  const double signal = transfer::dequantize_narrow(code, bits);
  return std::clamp(transfer::quantize_full(std::clamp(signal, 0.0, 1.0), bits), 0, (1 << bits) - 1);
}

}  // namespace

std::optional<ScrgbPolicy> parse_scrgb_policy(std::string_view s) {
  if (s == "convert") return ScrgbPolicy::convert;
  if (s == "refuse") return ScrgbPolicy::refuse;
  if (s == "passthrough") return ScrgbPolicy::passthrough;
  return std::nullopt;
}

int scanout_bytes_per_pixel(std::uint32_t fourcc) {
  if (fourcc == kDrmFormatXbgr2101010 || fourcc == kDrmFormatXrgb8888) return 4;
  if (fourcc == kDrmFormatAbgr16161616f) return 8;
  return 0;
}

Result<void> check_frame(const EncodedFrame& f) {
  const int bpp = scanout_bytes_per_pixel(f.drm_fourcc);
  if (!bpp)
    return make_error("scanout.format", fmt::format("fourcc {} cannot be scanned out (XB30, AB4H or XR24)",
                                                    fourcc_name(f.drm_fourcc)), "fourcc");
  if (auto s = check_image_size(f.width, f.height); !s) return s;
  if (f.stride_bytes < static_cast<std::size_t>(f.width) * bpp)
    return make_error("scanout.stride", fmt::format("stride {} bytes is less than width {} x {} bytes", f.stride_bytes,
                                                    f.width, bpp), "stride_bytes");
  if (f.data.size() < f.stride_bytes * static_cast<std::size_t>(f.height - 1) + static_cast<std::size_t>(f.width) * bpp)
    return make_error("scanout.size", fmt::format("buffer is {} bytes; {}x{} at stride {} needs {}", f.data.size(),
                                                  f.width, f.height, f.stride_bytes, f.stride_bytes * f.height), "data");
  const bool fp16 = f.drm_fourcc == kDrmFormatAbgr16161616f;
  if (fp16 != (f.target.mode == Mode::scrgb))
    return make_error("scanout.format", fmt::format("fourcc {} does not fit mode {}", fourcc_name(f.drm_fourcc),
                                                    to_string(f.target.mode)), "fourcc");
  if ((f.target.mode == Mode::hdr10 || f.target.mode == Mode::hlg) && f.drm_fourcc != kDrmFormatXbgr2101010)
    return make_error("scanout.format", fmt::format("{} frames are XB30, not {}", to_string(f.target.mode),
                                                    fourcc_name(f.drm_fourcc)), "fourcc");
  return {};
}

Result<EncodedFrame> scrgb_to_hdr10(const EncodedFrame& in) {
  if (in.drm_fourcc != kDrmFormatAbgr16161616f)
    return make_error("scanout.format", "scRGB conversion needs an AB4H (FP16) frame", "fourcc");
  EncodedFrame out;
  out.target = in.target;
  out.target.mode = Mode::hdr10;
  out.target.bits = 10;
  out.target.range = Range::full;
  out.width = in.width;
  out.height = in.height;
  out.drm_fourcc = kDrmFormatXbgr2101010;
  out.stride_bytes = static_cast<std::size_t>(in.width) * 4;
  out.data.assign(out.stride_bytes * in.height, 0);
  out.mastering = in.mastering;
  out.settings = in.settings;
  const color::Mat3 to2020 = color::rgb_to_rgb(color::kRec709, color::kRec2020);
  // No code above the peak's (the encoder's rule, encode/kernel/pipeline_internal.hpp
  // peak_code): the largest code whose light is at most the peak, not the nearest.
  int top = 1023;
  while (top > 0 && transfer::pq_eotf(transfer::dequantize_full(top, 10)) > in.target.peak_nits) --top;
  double max_cll = 0, max_fall = 0, sum = 0;
  for (int y = 0; y < in.height; ++y) {
    const std::uint8_t* src = in.data.data() + static_cast<std::size_t>(y) * in.stride_bytes;
    std::uint8_t* dst = out.data.data() + static_cast<std::size_t>(y) * out.stride_bytes;
    for (int x = 0; x < in.width; ++x) {
      auto half = [&](int c) { return half_to_double(static_cast<std::uint16_t>(src[8 * x + 2 * c] | (src[8 * x + 2 * c + 1] << 8))); };
      color::Vec3 nits = to2020 * color::Vec3{half(0), half(1), half(2)} * transfer::kScrgbUnitNits;
      auto clip = [&](double v) { return std::isfinite(v) ? std::clamp(v, 0.0, in.target.peak_nits) : 0.0; };
      nits = {clip(nits.x), clip(nits.y), clip(nits.z)};
      const double m = std::max({nits.x, nits.y, nits.z});
      max_cll = std::max(max_cll, m);
      sum += m;
      auto code = [top](double v) { return std::min(transfer::quantize_full(transfer::pq_inverse_eotf(v), 10), top); };
      store32(dst + 4 * x, pack_xbgr2101010(code(nits.x), code(nits.y), code(nits.z)));
    }
  }
  max_fall = in.width && in.height ? sum / (double(in.width) * in.height) : 0.0;
  out.content_light = {max_cll, max_fall};
  return out;
}

Result<EncodedFrame> narrow_to_full_range(const EncodedFrame& in) {
  EncodedFrame out = in;
  out.target.range = Range::full;
  for (int y = 0; y < in.height; ++y) {
    std::uint8_t* row = out.data.data() + static_cast<std::size_t>(y) * out.stride_bytes;
    for (int x = 0; x < in.width; ++x) {
      std::uint8_t* px = row + 4 * x;
      if (in.drm_fourcc == kDrmFormatXbgr2101010) {
        const std::uint32_t v = load32(px);
        store32(px, pack_xbgr2101010(narrow_to_full(v & 0x3ff, 10), narrow_to_full((v >> 10) & 0x3ff, 10),
                                     narrow_to_full((v >> 20) & 0x3ff, 10)) | (v & 0xc0000000u));
      } else if (in.drm_fourcc == kDrmFormatXrgb8888) {
        for (int c = 0; c < 3; ++c) px[c] = static_cast<std::uint8_t>(narrow_to_full(px[c], 8));
      } else {
        return make_error("scanout.range", "only integer formats have a narrow range", "range");
      }
    }
  }
  return out;
}

Result<ScanoutFrame> prepare_for_scanout(const EncodedFrame& frame, ScrgbPolicy policy) {
  if (auto c = check_frame(frame); !c) return c.error();
  ScanoutFrame s;
  if (frame.target.mode == Mode::scrgb) {
    if (policy == ScrgbPolicy::refuse)
      return make_error("scanout.scrgb", "scRGB cannot be signalled to KMS (no colorimetry or EOTF describes it); "
                                         "re-encode as hdr10 or let present convert it", "display.mode");
    if (policy == ScrgbPolicy::convert) {
      auto c = scrgb_to_hdr10(frame);
      if (!c) return c.error();
      s.frame = std::move(*c);
      s.notes.push_back("scRGB converted to HDR10 for KMS (Rec.2020 PQ, 10-bit full range); "
                        "MaxCLL/MaxFALL measured on the converted frame");
      return s;
    }
    s.frame = frame;
    s.notes.push_back("scRGB passed through as raw FP16 with no HDR signalling: correct only on drivers that "
                      "treat FP16 planes as scRGB");
    return s;
  }
  if (frame.target.range == Range::narrow) {
    auto c = narrow_to_full_range(frame);
    if (!c) return c.error();
    s.frame = std::move(*c);
    s.notes.push_back("narrow-range codes expanded to full range: KMS scan-out is full range");
    return s;
  }
  s.frame = frame;
  return s;
}

}  // namespace hdrd::display
