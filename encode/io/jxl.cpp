// JPEG XL writer on libjxl 0.7: the frame's signal with its colour encoding (ISO/IEC 18181-1
// §E: primaries, white point, transfer function as enums, no ICC), intensity_target = the
// target peak. Lossy frames go through XYB at a butteraugli distance; lossless ones are
// modular with the original profile, so the decoded samples are the PNG's.
#include <algorithm>
#include <cmath>
#include <memory>
#include <thread>

#include <fmt/format.h>
#include <jxl/encode.h>
#include <jxl/thread_parallel_runner.h>

#include "encode/colour/transfer.hpp"
#include "encode/io/internal.hpp"
#include "encode/io/signal_metadata.hpp"
#include "encode/io/io.hpp"
#include "encode/io/stills.hpp"

namespace hdrd::io {
namespace {

struct EncoderDeleter {
  void operator()(JxlEncoder* e) const { JxlEncoderDestroy(e); }
};
struct RunnerDeleter {
  void operator()(void* r) const { JxlThreadParallelRunnerDestroy(r); }
};

Error jxl_error(const std::string& what) { return make_error("jxl.encode", "libjxl cannot encode the frame: " + what); }

Result<void> check_options(const JxlOptions& o) {
  if (!o.lossless && (o.quality < 0 || o.quality > 100))
    return make_error("jxl.options", fmt::format("JPEG XL quality {} is outside 0..100", o.quality), "jxl.quality");
  if (o.effort < 1 || o.effort > 9)
    return make_error("jxl.options", fmt::format("JPEG XL effort {} is outside 1..9", o.effort), "jxl.effort");
  if (o.threads < 0) return make_error("jxl.options", "JPEG XL threads must be >= 0", "jxl.threads");
  return {};
}

// cjxl's --quality -> distance mapping (libjxl JxlEncoderDistanceFromQuality, 0.9):
// 90 -> 1.0 (visually lossless), 30 -> 6.4; 0.1 at the top, since 0 is lossless's.
double distance_for(int quality) {
  const double q = quality;
  const double d = q >= 30 ? 0.1 + (100 - q) * 0.09 : 53.0 / 3000.0 * q * q - 23.0 / 20.0 * q + 25.0;
  return std::clamp(d, 0.1, 25.0);
}

// The colour encoding that says what the samples are (the same code points as the PNG's cICP).
JxlColorEncoding colour_encoding(const DisplayTarget& t) {
  JxlColorEncoding c{};
  c.color_space = JXL_COLOR_SPACE_RGB;
  c.white_point = JXL_WHITE_POINT_D65;
  c.rendering_intent = JXL_RENDERING_INTENT_RELATIVE;
  const H273 cicp = h273(t);
  c.primaries = cicp.primaries == 9 ? JXL_PRIMARIES_2100 : JXL_PRIMARIES_SRGB;
  switch (cicp.transfer) {
    case 16: c.transfer_function = JXL_TRANSFER_FUNCTION_PQ; break;
    case 18: c.transfer_function = JXL_TRANSFER_FUNCTION_HLG; break;
    case 1: c.transfer_function = JXL_TRANSFER_FUNCTION_709; break;
    case 4:  // a pure 2.2 power: JPEG XL's gamma is the encoding exponent
      c.transfer_function = JXL_TRANSFER_FUNCTION_GAMMA;
      c.gamma = 1.0 / 2.2;
      break;
    default: c.transfer_function = JXL_TRANSFER_FUNCTION_SRGB; break;
  }
  return c;
}

// Interleaved RGB samples: 8-bit codes for 8-bit SDR, else 16-bit full-range samples, the
// PNG's own for full-range frames, round(E' 65535) of the dequantised code for narrow ones.
std::vector<std::uint8_t> pixels_of(const EncodedFrame& f, bool sixteen) {
  const std::size_t n = static_cast<std::size_t>(f.width) * f.height * 3;
  std::vector<std::uint8_t> out(sixteen ? n * 2 : n);
  auto* out16 = reinterpret_cast<std::uint16_t*>(out.data());
  const bool narrow = f.target.range == Range::narrow;
  const int bits = sixteen ? 10 : 8;
  std::size_t i = 0;
  for (int y = 0; y < f.height; ++y)
    for (int x = 0; x < f.width; ++x)
      for (int c = 0; c < 3; ++c, ++i) {
        if (!narrow) {
          if (sixteen) out16[i] = detail::sample16(f, x, y, c);
          else out[i] = static_cast<std::uint8_t>(detail::code_at(f, x, y, c));
          continue;
        }
        const double e = std::clamp(transfer::dequantize_narrow(detail::code_at(f, x, y, c), bits), 0.0, 1.0);
        if (sixteen) out16[i] = static_cast<std::uint16_t>(std::lround(e * 65535));
        else out[i] = static_cast<std::uint8_t>(std::lround(e * 255));
      }
  return out;
}

Result<void> configure(JxlEncoder* enc, const EncodedFrame& f, const JxlOptions& o, bool sixteen) {
  JxlBasicInfo info;
  JxlEncoderInitBasicInfo(&info);
  info.xsize = static_cast<std::uint32_t>(f.width);
  info.ysize = static_cast<std::uint32_t>(f.height);
  info.num_color_channels = 3;
  // libjxl 0.7 reads UINT16 input as 0 .. 2^bits_per_sample - 1 (no JxlEncoderSetFrameBitDepth
  // before 0.8): declaring 10 bits for 16-bit samples clips them. 16 keeps the PNG's precision.
  info.bits_per_sample = sixteen ? 16 : 8;
  info.uses_original_profile = o.lossless ? JXL_TRUE : JXL_FALSE;  // lossless: no XYB
  info.intensity_target = static_cast<float>(f.target.peak_nits);
  info.min_nits = f.target.is_hdr() ? static_cast<float>(f.mastering.min_nits) : 0.0f;
  if (JxlEncoderSetBasicInfo(enc, &info) != JXL_ENC_SUCCESS) return jxl_error("basic info rejected");
  const JxlColorEncoding colour = colour_encoding(f.target);
  if (JxlEncoderSetColorEncoding(enc, &colour) != JXL_ENC_SUCCESS) return jxl_error("colour encoding rejected");
  return {};
}

Result<std::vector<std::uint8_t>> drain(JxlEncoder* enc) {
  std::vector<std::uint8_t> out(64 * 1024);
  std::uint8_t* next = out.data();
  std::size_t avail = out.size();
  for (;;) {
    const JxlEncoderStatus s = JxlEncoderProcessOutput(enc, &next, &avail);
    if (s == JXL_ENC_SUCCESS) break;
    if (s != JXL_ENC_NEED_MORE_OUTPUT) return jxl_error("JxlEncoderProcessOutput failed");
    const std::size_t used = static_cast<std::size_t>(next - out.data());
    out.resize(out.size() * 2);
    next = out.data() + used;
    avail = out.size() - used;
  }
  out.resize(static_cast<std::size_t>(next - out.data()));
  return out;
}

}  // namespace

Result<std::vector<std::uint8_t>> encode_jxl(const EncodedFrame& frame, const JxlOptions& options) {
  if (frame.target.mode == Mode::scrgb)
    return make_error("jxl.unsupported", "scrgb is written as EXR; JPEG XL of it is not supported", "format");
  if (auto ok = detail::check_frame(frame); !ok) return ok.error();
  if (auto ok = check_options(options); !ok) return ok.error();
  const bool sixteen = frame.drm_fourcc != kDrmFormatXrgb8888;
  std::unique_ptr<JxlEncoder, EncoderDeleter> enc(JxlEncoderCreate(nullptr));
  const std::size_t threads = options.threads > 0 ? static_cast<std::size_t>(options.threads)
                                                  : std::max(1u, std::thread::hardware_concurrency());
  std::unique_ptr<void, RunnerDeleter> runner(JxlThreadParallelRunnerCreate(nullptr, threads));
  if (!enc || !runner) return jxl_error("cannot create the encoder");
  if (JxlEncoderSetParallelRunner(enc.get(), JxlThreadParallelRunner, runner.get()) != JXL_ENC_SUCCESS)
    return jxl_error("cannot attach the thread pool");
  if (auto ok = configure(enc.get(), frame, options, sixteen); !ok) return ok.error();
  JxlEncoderFrameSettings* fs = JxlEncoderFrameSettingsCreate(enc.get(), nullptr);
  if (!fs) return jxl_error("cannot create frame settings");
  JxlEncoderSetFrameLossless(fs, options.lossless ? JXL_TRUE : JXL_FALSE);
  if (!options.lossless) JxlEncoderSetFrameDistance(fs, static_cast<float>(distance_for(options.quality)));
  JxlEncoderFrameSettingsSetOption(fs, JXL_ENC_FRAME_SETTING_EFFORT, options.effort);
  const std::vector<std::uint8_t> pixels = pixels_of(frame, sixteen);
  const JxlPixelFormat format{3, sixteen ? JXL_TYPE_UINT16 : JXL_TYPE_UINT8, JXL_NATIVE_ENDIAN, 0};
  if (JxlEncoderAddImageFrame(fs, &format, pixels.data(), pixels.size()) != JXL_ENC_SUCCESS)
    return jxl_error("the frame's pixels were rejected");
  JxlEncoderCloseInput(enc.get());
  return drain(enc.get());
}

Result<void> write_jxl(const std::filesystem::path& path, const EncodedFrame& frame, const JxlOptions& options) {
  auto bytes = encode_jxl(frame, options);
  if (!bytes) return bytes.error();
  return atomic_write(path, *bytes);
}

}  // namespace hdrd::io
