// AVIF writer: libavif 0.11 with libaom (Debian 12 builds libavif with aom, rav1e and SVT-AV1;
// aom is the one that does 4:4:4, 12-bit and lossless). libavif converts R'G'B' to Y'CbCr
// (H.273 matrix, range, chroma averaging); identity (RGB) planes are filled here from the
// frame's codes so that lossless means the codes themselves. clli and mdcv are added to the
// container afterwards (avif_boxes.hpp says why).
#include <algorithm>
#include <cmath>
#include <memory>
#include <thread>

#include <avif/avif.h>
#include <fmt/format.h>

#include "encode/colour/transfer.hpp"
#include "encode/io/avif_boxes.hpp"
#include "encode/io/internal.hpp"
#include "encode/io/signal_metadata.hpp"
#include "encode/io/io.hpp"
#include "encode/io/stills.hpp"

namespace hdrd::io {
namespace {

struct AvifImageDeleter {
  void operator()(avifImage* p) const { avifImageDestroy(p); }
};
struct AvifEncoderDeleter {
  void operator()(avifEncoder* p) const { avifEncoderDestroy(p); }
};
struct RwData {
  avifRWData d = AVIF_DATA_EMPTY;
  ~RwData() { avifRWDataFree(&d); }
};

// Options with the frame's defaults filled in, checked.
struct AvifPlan {
  int bits = 10;
  Range range = Range::full;
  AvifMatrix matrix = AvifMatrix::ycbcr;
  ChromaSubsampling chroma = ChromaSubsampling::yuv420;
  int speed = 7;
};

Error option_error(std::string message, std::string field) {
  return make_error("avif.options", std::move(message), std::move(field));
}

Result<AvifPlan> plan_for(const EncodedFrame& frame, const AvifOptions& o) {
  AvifPlan p;
  const bool eight_bit_frame = frame.drm_fourcc == kDrmFormatXrgb8888;
  p.bits = o.bits != 0 ? o.bits : (eight_bit_frame ? 8 : 10);
  if (p.bits != 8 && p.bits != 10 && p.bits != 12)
    return option_error(fmt::format("AVIF bit depth {} is not 8, 10 or 12", o.bits), "avif.bits");
  p.range = o.range.value_or(frame.target.range);
  p.matrix = o.matrix.value_or(o.lossless ? AvifMatrix::rgb : AvifMatrix::ycbcr);
  const bool full_chroma = o.lossless || p.matrix == AvifMatrix::rgb;
  p.chroma = o.chroma.value_or(full_chroma ? ChromaSubsampling::yuv444 : ChromaSubsampling::yuv420);
  if (p.matrix == AvifMatrix::rgb && p.chroma != ChromaSubsampling::yuv444)
    return option_error("AVIF with the identity matrix (rgb) needs 4:4:4 chroma (H.273: MC 0 has no subsampling)",
                        "avif.chroma");
  if (o.lossless && p.matrix != AvifMatrix::rgb)
    return option_error("lossless AVIF needs the identity matrix (rgb): Y'CbCr conversion is not lossless",
                        "avif.matrix");
  if (o.lossless && p.bits != (eight_bit_frame ? 8 : 10))
    return option_error(fmt::format("lossless AVIF keeps the frame's {}-bit codes; {} bits would requantise them",
                                    eight_bit_frame ? 8 : 10, p.bits),
                        "avif.bits");
  if (o.lossless && p.range != frame.target.range)
    return option_error("lossless AVIF keeps the frame's range; another range would requantise its codes",
                        "avif.range");
  if (!o.lossless && (o.quality < 0 || o.quality > 100))
    return option_error(fmt::format("AVIF quality {} is outside 0..100", o.quality), "avif.quality");
  p.speed = o.speed.value_or(o.lossless ? 9 : 7);
  if (p.speed < 0 || p.speed > 9) return option_error(fmt::format("AVIF speed {} is outside 0..9", p.speed), "avif.speed");
  if (o.threads < 0) return option_error("AVIF threads must be >= 0", "avif.threads");
  return p;
}

// The signal E' of one sample, from the most precise thing the frame holds.
double signal_at(const EncodedFrame& f, int x, int y, int c) {
  const int bits = f.drm_fourcc == kDrmFormatXrgb8888 ? 8 : 10;
  if (f.target.range == Range::full && !f.signal16.empty())
    return f.signal16[(static_cast<std::size_t>(y) * f.width + x) * 3 + c] / 65535.0;
  const int code = detail::code_at(f, x, y, c);
  return f.target.range == Range::full ? transfer::dequantize_full(code, bits) : transfer::dequantize_narrow(code, bits);
}

// Identity matrix: Y = G, Cb = B, Cr = R (H.273 eq. for MC 0). The frame's codes as they
// are when bits and range match (lossless), else the signal requantised.
void fill_identity(const EncodedFrame& f, const AvifPlan& p, avifImage& img) {
  const int frame_bits = f.drm_fourcc == kDrmFormatXrgb8888 ? 8 : 10;
  const bool same = p.bits == frame_bits && p.range == f.target.range;
  const int source_channel[3] = {1, 2, 0};
  for (int plane = 0; plane < 3; ++plane) {
    std::uint8_t* row = img.yuvPlanes[plane];
    for (int y = 0; y < f.height; ++y, row += img.yuvRowBytes[plane]) {
      for (int x = 0; x < f.width; ++x) {
        const int c = source_channel[plane];
        const int v = same ? detail::code_at(f, x, y, c)
                           : (p.range == Range::full ? transfer::quantize_full(signal_at(f, x, y, c), p.bits)
                                                     : transfer::quantize_narrow(signal_at(f, x, y, c), p.bits));
        if (p.bits == 8) row[x] = static_cast<std::uint8_t>(v);
        else reinterpret_cast<std::uint16_t*>(row)[x] = static_cast<std::uint16_t>(v);
      }
    }
  }
}

// Y'CbCr: libavif converts full-range 16-bit R'G'B' (the signal) with the image's matrix and
// range, averaging chroma for 4:2:2 / 4:2:0.
Result<void> fill_ycbcr(const EncodedFrame& f, avifImage& img) {
  avifRGBImage rgb;
  avifRGBImageSetDefaults(&rgb, &img);
  rgb.format = AVIF_RGB_FORMAT_RGB;
  rgb.depth = 16;
  rgb.chromaDownsampling = AVIF_CHROMA_DOWNSAMPLING_AVERAGE;
  avifRGBImageAllocatePixels(&rgb);
  std::unique_ptr<avifRGBImage, void (*)(avifRGBImage*)> guard(&rgb, avifRGBImageFreePixels);
  const bool direct = f.target.range == Range::full && f.drm_fourcc != kDrmFormatXrgb8888;
  for (int y = 0; y < f.height; ++y) {
    auto* row = reinterpret_cast<std::uint16_t*>(rgb.pixels + static_cast<std::size_t>(y) * rgb.rowBytes);
    for (int x = 0; x < f.width; ++x)
      for (int c = 0; c < 3; ++c)
        row[x * 3 + c] = direct ? detail::sample16(f, x, y, c)
                                : static_cast<std::uint16_t>(std::lround(std::clamp(signal_at(f, x, y, c), 0.0, 1.0) * 65535));
  }
  if (const avifResult r = avifImageRGBToYUV(&img, &rgb); r != AVIF_RESULT_OK)
    return make_error("avif.encode", fmt::format("libavif cannot convert R'G'B' to Y'CbCr: {}", avifResultToString(r)));
  return {};
}

avifPixelFormat pixel_format(ChromaSubsampling c) {
  switch (c) {
    case ChromaSubsampling::yuv444: return AVIF_PIXEL_FORMAT_YUV444;
    case ChromaSubsampling::yuv422: return AVIF_PIXEL_FORMAT_YUV422;
    case ChromaSubsampling::yuv420: return AVIF_PIXEL_FORMAT_YUV420;
  }
  return AVIF_PIXEL_FORMAT_YUV444;
}

// libavif 1.0's quality -> quantiser mapping (avif.h: quantizer = ((100 - quality) * 63 + 50) / 100),
// so `quality` means what it means to avifenc -q in later releases.
int quantizer_for(int quality) { return ((100 - quality) * 63 + 50) / 100; }

// clli (CTA-861.3, u16 cd/m2) and mdcv (SMPTE ST 2086 in HEVC SEI order G, B, R; ISO/IEC
// 23008-2 D.3.28, which the HEIF mdcv box takes its semantics from).
std::vector<std::vector<std::uint8_t>> hdr_properties(const EncodedFrame& f) {
  std::vector<std::uint8_t> clli, mdcv;
  const auto put = [](std::vector<std::uint8_t>& v, std::uint32_t x, int n) {
    for (int s = 8 * (n - 1); s >= 0; s -= 8) v.push_back(static_cast<std::uint8_t>(x >> s));
  };
  const Cta861Light light = cta861_light(f.content_light, f.mastering);
  put(clli, light.max_cll, 2);
  put(clli, light.max_fall, 2);
  const St2086Codes u = st2086_codes(f.mastering);
  for (const auto& xy : {u.green, u.blue, u.red, u.white}) put(mdcv, xy[0], 2), put(mdcv, xy[1], 2);
  put(mdcv, u.max_luminance, 4);
  put(mdcv, u.min_luminance, 4);
  return {detail::make_box("clli", clli), detail::make_box("mdcv", mdcv)};
}

std::unique_ptr<avifEncoder, AvifEncoderDeleter> make_encoder(const AvifOptions& o, const AvifPlan& p) {
  std::unique_ptr<avifEncoder, AvifEncoderDeleter> enc(avifEncoderCreate());
  if (!enc) return enc;
  enc->codecChoice = AVIF_CODEC_CHOICE_AOM;
  enc->maxThreads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  enc->speed = p.speed;
  enc->autoTiling = AVIF_TRUE;  // tiles let aom's threads share a 4K frame
  const int q = o.lossless ? AVIF_QUANTIZER_LOSSLESS : quantizer_for(o.quality);
  enc->minQuantizer = enc->maxQuantizer = q;
  return enc;
}

}  // namespace

Result<std::vector<std::uint8_t>> encode_avif(const EncodedFrame& frame, const AvifOptions& options) {
  if (frame.target.mode == Mode::scrgb)
    return make_error("avif.unsupported", "scrgb has no AVIF form (AVIF has no linear FP16 signal); use exr", "format");
  if (auto ok = detail::check_frame(frame); !ok) return ok.error();
  const auto plan = plan_for(frame, options);
  if (!plan) return plan.error();
  std::unique_ptr<avifImage, AvifImageDeleter> img(
      avifImageCreate(static_cast<std::uint32_t>(frame.width), static_cast<std::uint32_t>(frame.height),
                      static_cast<std::uint32_t>(plan->bits), pixel_format(plan->chroma)));
  if (!img) return make_error("avif.encode", "libavif cannot allocate an image");
  const H273 cicp = h273(frame.target);
  img->colorPrimaries = cicp.primaries;
  img->transferCharacteristics = cicp.transfer;
  img->matrixCoefficients = plan->matrix == AvifMatrix::rgb ? 0 : ycbcr_matrix(frame.target);
  img->yuvRange = plan->range == Range::full ? AVIF_RANGE_FULL : AVIF_RANGE_LIMITED;
  if (plan->matrix == AvifMatrix::rgb) {
    avifImageAllocatePlanes(img.get(), AVIF_PLANES_YUV);
    fill_identity(frame, *plan, *img);
  } else if (auto ok = fill_ycbcr(frame, *img); !ok) {
    return ok.error();
  }
  auto enc = make_encoder(options, *plan);
  if (!enc) return make_error("avif.encode", "libavif cannot create an encoder");
  RwData out;
  if (const avifResult r = avifEncoderWrite(enc.get(), img.get(), &out.d); r != AVIF_RESULT_OK)
    return make_error("avif.encode", fmt::format("libavif/aom cannot encode the frame: {}{}{}", avifResultToString(r),
                                                 enc->diag.error[0] ? ": " : "", enc->diag.error));
  const std::span<const std::uint8_t> bytes(out.d.data, out.d.size);
  if (frame.target.mode != Mode::hdr10 && frame.target.mode != Mode::hlg)
    return std::vector<std::uint8_t>(bytes.begin(), bytes.end());
  return detail::add_item_properties(bytes, hdr_properties(frame));
}

Result<void> write_avif(const std::filesystem::path& path, const EncodedFrame& frame, const AvifOptions& options) {
  auto bytes = encode_avif(frame, options);
  if (!bytes) return bytes.error();
  return atomic_write(path, *bytes);
}

}  // namespace hdrd::io
