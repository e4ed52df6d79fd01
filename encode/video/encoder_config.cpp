#include "encode/video/encoder_config.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <fmt/format.h>

extern "C" {
#include <libavcodec/avcodec.h>
}

#include "encode/image.hpp"

namespace hdrd::video {

namespace {

constexpr std::array<std::string_view, 10> kX26xPresets{"ultrafast", "superfast", "veryfast", "faster", "fast",
                                                        "medium",    "slow",      "slower",   "veryslow", "placebo"};

std::string av1_encoder_of(const VideoSettings& s) {
  if (s.lossless) return "libaom-av1";  // SVT-AV1 1.4 has no lossless mode
  return s.av1_encoder.empty() ? "libsvtav1" : s.av1_encoder;
}

std::string encoder_of(const VideoSettings& s) {
  switch (s.codec) {
    case Codec::hevc: return "libx265";
    case Codec::h264: return "libx264";
    case Codec::av1: return av1_encoder_of(s);
  }
  return "";
}

struct CrfRange {
  double lo, hi;
  bool integer;
};
CrfRange crf_range(const std::string& encoder) {
  if (encoder == "libsvtav1") return {1, 63, true};
  if (encoder == "libaom-av1") return {0, 63, true};
  return {0, 51, false};  // x265, x264
}

bool is_integer_in(const std::string& s, int lo, int hi) {
  if (s.empty() || s.size() > 2 || !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; })) return false;
  const int v = std::stoi(s);
  return v >= lo && v <= hi;
}

Result<void> check_preset(const std::string& encoder, const std::string& preset) {
  if (preset.empty()) return {};
  bool ok = false;
  std::string accepted;
  if (encoder == "libx265" || encoder == "libx264") {
    ok = std::find(kX26xPresets.begin(), kX26xPresets.end(), preset) != kX26xPresets.end();
    accepted = "ultrafast, superfast, veryfast, faster, fast, medium, slow, slower, veryslow or placebo";
  } else if (encoder == "libsvtav1") {
    ok = is_integer_in(preset, 0, 13);
    accepted = "0 (slowest) to 13 (fastest)";
  } else {
    ok = is_integer_in(preset, 0, 8);
    accepted = "cpu-used 0 (slowest) to 8 (fastest)";
  }
  if (!ok)
    return make_error("video.preset", fmt::format("{} has no preset '{}': use {}", encoder, preset, accepted), "video.preset");
  return {};
}

std::string join_params(const std::vector<std::string>& p) {
  std::string s;
  for (const auto& x : p) s += (s.empty() ? "" : ":") + x;
  return s;
}

// x265's frame-thread ladder for a machine with `threads` cores (its own auto rule), taken
// from the setting rather than the machine, so the bitstream does not depend on it.
int x265_frame_threads(int threads) { return threads >= 16 ? 5 : threads >= 8 ? 3 : threads >= 4 ? 2 : 1; }

std::string profile_of(const VideoSettings& s, int bits) {
  switch (s.codec) {
    case Codec::hevc: return bits == 10 ? "Main 10" : "Main";
    case Codec::av1: return "Main";
    case Codec::h264: return s.lossless ? "High 4:4:4 Predictive" : bits == 10 ? "High 10" : "High";
  }
  return "";
}

}  // namespace

double default_crf(Codec c) {
  switch (c) {
    case Codec::hevc: return 22;
    case Codec::av1: return 30;
    case Codec::h264: return 20;
  }
  return 22;
}

std::string default_preset(const VideoSettings& s) {
  const std::string e = encoder_of(s);
  if (e == "libsvtav1") return "10";
  if (e == "libaom-av1") return "6";
  return "medium";
}

Result<void> validate(const VideoSettings& s) {
  if (s.fps_num <= 0 || s.fps_den <= 0 || static_cast<double>(s.fps_num) / s.fps_den > 1000)
    return make_error("video.fps", fmt::format("frame rate {}/{} is not within (0, 1000] fps", s.fps_num, s.fps_den), "fps");
  if (!(s.keyframe_interval_s > 0 && s.keyframe_interval_s <= 3600))
    return make_error("video.keyframe_interval", fmt::format("keyframe interval {} s is not within (0, 3600]", s.keyframe_interval_s),
                      "video.keyframe_interval_s");
  if (s.threads < 1 || s.threads > 64)
    return make_error("video.threads", fmt::format("{} encoder threads is not within [1, 64]", s.threads), "video.threads");
  if (s.codec == Codec::av1 && !s.av1_encoder.empty() && s.av1_encoder != "libsvtav1" && s.av1_encoder != "libaom-av1")
    return make_error("video.encoder", fmt::format("no AV1 encoder '{}': use libsvtav1 or libaom-av1", s.av1_encoder),
                      "video.av1_encoder");
  if (s.codec == Codec::av1 && s.lossless && s.av1_encoder == "libsvtav1")
    return make_error("video.lossless", "SVT-AV1 1.4 has no lossless mode: lossless AV1 uses libaom-av1", "video.lossless");
  const std::string e = encoder_of(s);
  if (s.crf && !s.lossless) {
    const CrfRange r = crf_range(e);
    if (!(*s.crf >= r.lo && *s.crf <= r.hi) || (r.integer && *s.crf != std::floor(*s.crf)))
      return make_error("video.crf", fmt::format("{} takes {}crf {} to {}, not {}", e, r.integer ? "an integer " : "", r.lo, r.hi, *s.crf),
                        "video.crf");
  }
  return check_preset(e, s.preset);
}

Result<EncoderConfig> encoder_config(const VideoSettings& s, const StreamInfo& stream) {
  if (auto ok = validate(s); !ok) return ok.error();
  if (auto ok = check_image_size(stream.width, stream.height); !ok) return ok.error();
  if (stream.width % 2 || stream.height % 2)
    return make_error("video.size", fmt::format("4:2:0 video needs an even width and height, not {}x{}", stream.width, stream.height),
                      "size");
  const Mode mode = stream.target.mode;
  if (mode == Mode::scrgb)
    return make_error("video.mode", "scrgb is linear FP16 and has no Y'CbCr video form; use hdr10, hlg or sdr", "display.mode");
  if (s.codec == Codec::h264 && (mode == Mode::hdr10 || mode == Mode::hlg))
    return make_error("video.codec", fmt::format("H.264 video is for SDR only; {} takes hevc or av1", to_string(mode)), "video.codec");
  EncoderConfig c;
  c.encoder = encoder_of(s);
  c.bits = stream.target.bits;
  if (c.bits != 8 && c.bits != 10)
    return make_error("video.format", fmt::format("{}-bit {} has no 4:2:0 video form (8 or 10 bits)", c.bits, to_string(mode)),
                      "display.bits");
  if ((mode == Mode::hdr10 || mode == Mode::hlg) && c.bits != 10)
    return make_error("video.format", "HDR video is 10-bit", "display.bits");
  // Debian 12's libx265 3.5 writes past a lookahead buffer (Lookahead::cuTree, seen by
  // valgrind at 32x16 and 48x32) for frames under 64 pixels wide: refused, not risked.
  if (c.encoder == "libx265" && stream.width < 64)
    return make_error("video.size", fmt::format("x265 needs frames at least 64 pixels wide, not {}x{}", stream.width,
                                                stream.height),
                      "size");
  // ... and at least 16 rows: Debian 12's libx265 3.5 refuses fewer in avcodec_open2 (EINVAL,
  // "Picture size must be at least one CTU": 16 is its smallest CTU), at every preset
  // (measured: 64x8 to 64x14 and 256x2 fail, 64x16 works with ultrafast and medium).
  if (c.encoder == "libx265" && stream.height < 16)
    return make_error("video.size", fmt::format("x265 needs frames at least 16 pixels high, not {}x{}", stream.width,
                                                stream.height),
                      "size");
  if (c.encoder == "libsvtav1" && (stream.width < 64 || stream.height < 64))
    return make_error("video.size", fmt::format("SVT-AV1 needs frames of at least 64x64, not {}x{}", stream.width, stream.height),
                      "size");
  c.profile = profile_of(s, c.bits);
  c.tags = h273(stream.target);
  c.matrix = mode == Mode::hdr10 || mode == Mode::hlg ? io::kH273MatrixBt2020Ncl : io::kH273MatrixBt709;
  const double fps = static_cast<double>(s.fps_num) / s.fps_den;
  c.keyframe_interval = std::max(1, static_cast<int>(std::lround(s.keyframe_interval_s * fps)));

  const std::string preset = s.preset.empty() ? default_preset(s) : s.preset;
  const double crf = s.crf.value_or(default_crf(s.codec));
  const std::string k = std::to_string(c.keyframe_interval);
  if (c.encoder == "libx265") {
    c.options["preset"] = preset;
    std::vector<std::string> p{"keyint=" + k, "min-keyint=1", "open-gop=0", "chromaloc=0", "log-level=error",
                               // info=0: the encoder-info SEI lists the thread pool, which would
                               // make the bytes depend on the machine.
                               "info=0", fmt::format("frame-threads={}", x265_frame_threads(s.threads)),
                               fmt::format("pools={}", s.threads)};
    if (s.lossless)
      p.push_back("lossless=1");
    else
      c.options["crf"] = fmt::format("{}", crf);
    c.options["x265-params"] = join_params(p);
    c.options["forced-idr"] = "1";
  } else if (c.encoder == "libx264") {
    c.options["preset"] = preset;
    if (s.lossless)
      c.options["qp"] = "0";
    else
      c.options["crf"] = fmt::format("{}", crf);
    c.options["x264-params"] = join_params({"keyint=" + k, "min-keyint=1", "open-gop=0", "chromaloc=0"});
    c.options["forced-idr"] = "1";
  } else if (c.encoder == "libsvtav1") {
    c.options["preset"] = preset;
    c.options["crf"] = fmt::format("{}", static_cast<int>(crf));
    // FFmpeg 5.1's wrapper passes a frame's pict_type I on as EB_AV1_KEY_PICTURE, but SVT-AV1
    // 1.4 honours it only with enable-force-key-frames (without it a 5-scene sequence had one
    // keyframe, frame 0): so every scene cut is a keyframe, as with x265 and libaom.
    c.options["svtav1-params"] = "enable-force-key-frames=1";
  } else {  // libaom-av1
    c.options["cpu-used"] = preset;
    c.options["row-mt"] = "1";
    c.options["crf"] = s.lossless ? "0" : fmt::format("{}", static_cast<int>(crf));
    if (s.lossless) c.options["aom-params"] = "lossless=1";
  }
  return c;
}

Result<void> configure(const EncoderConfig& c, const VideoSettings& s, const StreamInfo& stream, AVCodecContext& ctx) {
  ctx.width = stream.width;
  ctx.height = stream.height;
  ctx.pix_fmt = c.bits == 10 ? AV_PIX_FMT_YUV420P10LE : AV_PIX_FMT_YUV420P;
  ctx.time_base = AVRational{s.fps_den, s.fps_num};
  ctx.framerate = AVRational{s.fps_num, s.fps_den};
  ctx.gop_size = c.keyframe_interval;
  ctx.thread_count = s.threads;
  ctx.color_primaries = static_cast<AVColorPrimaries>(c.tags.primaries);
  ctx.color_trc = static_cast<AVColorTransferCharacteristic>(c.tags.transfer);
  ctx.colorspace = static_cast<AVColorSpace>(c.matrix);
  ctx.color_range = s.range == Range::narrow ? AVCOL_RANGE_MPEG : AVCOL_RANGE_JPEG;
  ctx.chroma_sample_location = AVCHROMA_LOC_LEFT;  // ycbcr.hpp's siting
  ctx.bit_rate = 0;                                // constant quality
  ctx.flags |= AV_CODEC_FLAG_GLOBAL_HEADER;        // parameter sets in the sample entry (both containers)
  ctx.flags |= AV_CODEC_FLAG_BITEXACT;
  return {};
}

}  // namespace hdrd::video
