// Video: where a frame's time goes once it is encoded (docs/video.md).
//   bench_video --size 1080p --frames 24 --codec hevc
// For each frame, in one run and alternated: hdrd's own work (R'G'B' -> Y'CbCr 4:2:0, the
// frame light decoded from the codes, the sequence metadata update) timed alone, then the
// same frames through SequenceWriter (conversion + the encoder at its default preset +
// spooling, then the mux). Reports medians per frame, the encoder's share, and hdrd's work
// as a fraction of it. --rss-frames N: resident memory while N frames stream through the
// writer (bounded memory: it must stay flat).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <numeric>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include "encode/pipeline.hpp"
#include "encode/video/writer.hpp"
#include "encode/video/ycbcr.hpp"

using namespace hdrd;
using namespace hdrd::video;
using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;

namespace {

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

// CPU time, which a machine shared with other work does not inflate as it does wall time:
// this thread's (hdrd's own steps run on it) and the whole process's (the encoder's
// worker threads included).
double cpu_ms(clockid_t clock) {
  timespec t{};
  clock_gettime(clock, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}
double thread_cpu_ms() { return cpu_ms(CLOCK_THREAD_CPUTIME_ID); }
double process_cpu_ms() { return cpu_ms(CLOCK_PROCESS_CPUTIME_ID); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0 : v[v.size() / 2];
}

long rss_kib() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

// A render-like HDR frame (sky, a lit ground with texture, a sun glint), encoded by the
// hdrd pipeline; later frames pan it sideways, as a camera move would.
EncodedFrame base_frame(int w, int h, Mode mode) {
  Image img(w, h);
  std::uint32_t seed = 12345;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      seed = seed * 1664525u + 1013904223u;
      const float grain = 1.0f + ((seed >> 9) & 0xFF) / 255.0f * 0.2f - 0.1f;
      float* p = img.px(x, y);
      const float sky = y < h / 3 ? 4.0f * (1.0f - static_cast<float>(y) / h) : 0.0f;
      const float ground = y >= h / 3 ? 0.3f + 0.2f * std::sin(x * 0.05f) * std::cos(y * 0.03f) : 0.0f;
      const float dx = x - w * 0.7f, dy = y - h * 0.2f;
      const float sun = 40.0f * std::exp(-(dx * dx + dy * dy) / (0.0004f * w * w));
      p[0] = (sky * 0.8f + ground * 1.1f + sun) * grain;
      p[1] = (sky * 0.9f + ground * 0.9f + sun) * grain;
      p[2] = (sky * 1.2f + ground * 0.6f + sun) * grain;
      p[3] = 1;
    }
  EncodeSettings s;
  s.target = default_target(mode);
  SceneInput in;
  in.image = &img;
  return *encode_frame(in, s);
}

// Frame i: the base frame's rows rotated left by 6 i pixels.
void pan(const EncodedFrame& base, int i, EncodedFrame& out) {
  const std::size_t row = static_cast<std::size_t>(base.width) * 4, shift = static_cast<std::size_t>(6 * i % base.width) * 4;
  for (int y = 0; y < base.height; ++y) {
    const std::uint8_t* s = base.data.data() + static_cast<std::size_t>(y) * base.stride_bytes;
    std::uint8_t* d = out.data.data() + static_cast<std::size_t>(y) * out.stride_bytes;
    std::memcpy(d, s + shift, row - shift);
    std::memcpy(d + row - shift, s, shift);
  }
  out.content_light = measure_content_light(out);
}

struct Planes {
  std::vector<std::uint8_t> y, cb, cr;
  Planes420 view;
  Planes(int w, int h, int bits) {
    const std::size_t b = bits == 10 ? 2 : 1;
    y.resize(static_cast<std::size_t>(w) * h * b);
    cb.resize(y.size() / 4);
    cr.resize(y.size() / 4);
    const auto s = static_cast<std::ptrdiff_t>(w * b);
    view = {{y.data(), s}, {cb.data(), s / 2}, {cr.data(), s / 2}};
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hdrd video benchmark"};
  std::string size = "1080p", codec_name = "hevc", preset, av1_encoder, out_dir = fs::temp_directory_path().string();
  int frames = 24, rss_frames = 0, threads = 4;
  bool own_only = false;
  app.add_option("--size", size, "1080p or 4k");
  app.add_option("--frames", frames, "frames for the time split");
  app.add_option("--codec", codec_name, "hevc, av1 or h264");
  app.add_option("--preset", preset, "encoder preset (default: hdrd's default)");
  app.add_option("--av1-encoder", av1_encoder, "libsvtav1 or libaom-av1");
  app.add_option("--threads", threads, "encoder threads");
  app.add_option("--rss-frames", rss_frames, "stream this many frames and report resident memory (0: skip)");
  app.add_option("--out", out_dir, "directory for the video written");
  app.add_flag("--own-only", own_only, "time hdrd's own per-frame work alone (no encoder)");
  CLI11_PARSE(app, argc, argv);
  quiet_codec_logs();

  const int w = size == "4k" ? 3840 : 1920, h = size == "4k" ? 2160 : 1080;
  VideoSettings s;
  s.codec = *parse_codec(codec_name);
  s.preset = preset;
  s.av1_encoder = av1_encoder;
  s.threads = threads;
  const Mode mode = s.codec == Codec::h264 ? Mode::sdr : Mode::hdr10;
  const EncodedFrame base = base_frame(w, h, mode);
  EncodedFrame frame = base;
  const StreamInfo info{w, h, base.target, base.mastering};
  const YcbcrFormat ycbcr = *ycbcr_format_for(base, s.range);
  Planes planes(w, h, ycbcr.bits);
  std::printf("%s %dx%d, %s (%s preset %s), %d threads, %d frames\n", codec_name.c_str(), w, h, codec_name.c_str(),
              av1_encoder.empty() ? "default encoder" : av1_encoder.c_str(), (preset.empty() ? default_preset(s) : preset).c_str(),
              threads, frames);

  // hdrd's own per-frame work, each part alone, then the writer, frame by frame in turn.
  std::vector<double> t_convert, t_light, t_meta, t_write;
  SequenceMetadata meta(info.target, info.mastering);
  auto writer = SequenceWriter::open(fs::path(out_dir) / "bench_video", s, info);
  if (!writer) {
    std::fprintf(stderr, "%s\n", writer.error().message.c_str());
    return 1;
  }
  if (own_only) {
    std::vector<double> c_convert, c_light;
    for (int i = 0; i < frames; ++i) {
      pan(base, i, frame);
      auto t0 = Clock::now();
      double c0 = thread_cpu_ms();
      if (!rgb_to_ycbcr420(frame, ycbcr, planes.view).ok()) return 1;
      t_convert.push_back(ms_since(t0));
      c_convert.push_back(thread_cpu_ms() - c0);
      t0 = Clock::now();
      c0 = thread_cpu_ms();
      const FrameLight light = measure_frame_light(frame);
      t_light.push_back(ms_since(t0));
      c_light.push_back(thread_cpu_ms() - c0);
      if (light.pixels == 0) return 1;
    }
    std::printf("Y'CbCr 4:2:0 %.2f ms wall (min %.2f), %.2f ms CPU; frame light %.2f ms wall (min %.2f), %.2f ms CPU\n",
                median(t_convert), *std::min_element(t_convert.begin(), t_convert.end()), median(c_convert),
                median(t_light), *std::min_element(t_light.begin(), t_light.end()), median(c_light));
    return 0;
  }
  const auto all = Clock::now();
  double own_total = 0, own_cpu = 0, writer_cpu = 0;
  std::vector<double> c_own;
  for (int i = 0; i < frames; ++i) {
    pan(base, i, frame);
    auto t0 = Clock::now();
    const double c0 = thread_cpu_ms();
    if (!rgb_to_ycbcr420(frame, ycbcr, planes.view).ok()) return 1;
    t_convert.push_back(ms_since(t0));
    t0 = Clock::now();
    const FrameLight light = measure_frame_light(frame);
    t_light.push_back(ms_since(t0));
    t0 = Clock::now();
    if (!meta.add(light, i == 0).ok()) return 1;
    t_meta.push_back(ms_since(t0));
    own_total += t_convert.back() + t_light.back() + t_meta.back();
    c_own.push_back(thread_cpu_ms() - c0);
    own_cpu += c_own.back();
    t0 = Clock::now();
    const double p0 = process_cpu_ms();
    if (auto ok = (*writer)->write(frame); !ok) {
      std::fprintf(stderr, "%s\n", ok.error().message.c_str());
      return 1;
    }
    t_write.push_back(ms_since(t0));
    writer_cpu += process_cpu_ms() - p0;
  }
  meta.finish();
  auto t0 = Clock::now();
  const double p0 = process_cpu_ms();
  auto result = (*writer)->finish(&meta);
  const double t_finish = ms_since(t0);
  writer_cpu += process_cpu_ms() - p0;
  const double wall = ms_since(all) - own_total;  // the writer's part of the loop
  if (!result) {
    std::fprintf(stderr, "%s\n", result.error().message.c_str());
    return 1;
  }
  const double per_frame_writer = wall / frames;
  const double convert = median(t_convert), light = median(t_light), md = median(t_meta);
  const double encoder = per_frame_writer - convert;  // the writer converts too
  std::printf("| step | ms / frame |\n|---|---|\n");
  std::printf("| Y'CbCr 4:2:0 (hdrd) | %.2f |\n| frame light (hdrd) | %.2f |\n| metadata update (hdrd) | %.3f |\n", convert, light, md);
  std::printf("| encoder + spool (writer minus conversion, incl. flush) | %.1f |\n| finish: flush + mux (once: %.1f ms) | %.2f |\n",
              encoder, t_finish, t_finish / frames);
  std::printf("| write() median (encoder pipelining hides some) | %.1f |\n", median(t_write));
  std::printf("hdrd's own work (conversion + light + metadata) = %.2f %% of the encoder's wall time\n",
              100.0 * (convert + light + md) / encoder);
  // CPU: the writer's process CPU less its own conversion (one more, as timed alone).
  const double encoder_cpu = writer_cpu / frames - median(c_own) * convert / (convert + light + md);
  std::printf("CPU per frame: hdrd's own work %.2f ms, encoder (all its threads) %.1f ms: %.2f %%\n", median(c_own),
              encoder_cpu, 100.0 * median(c_own) / encoder_cpu);
  std::printf("file %s, %llu bytes\n", result->path.c_str(), static_cast<unsigned long long>(result->bytes));
  fs::remove(result->path);

  if (rss_frames > 0) {
    SequenceMetadata m2(info.target, info.mastering);
    auto w2 = SequenceWriter::open(fs::path(out_dir) / "bench_video_rss", s, info);
    if (!w2) return 1;
    std::printf("resident memory before the writer %ld KiB; over %d frames (KiB):", rss_kib(), rss_frames);
    std::vector<long> rss;
    for (int i = 0; i < rss_frames; ++i) {
      pan(base, i, frame);
      if (!m2.add(frame, i % 60 == 0).ok() || !(*w2)->write(frame, {i % 60 == 0}).ok()) return 1;
      if (i % 25 == 24) {
        rss.push_back(rss_kib());
        std::printf(" %ld", rss.back());
        std::fflush(stdout);
      }
    }
    m2.finish();
    auto r2 = (*w2)->finish(&m2);
    std::printf("\nafter finish: %ld KiB; growth from frame 50 to %d: %ld KiB\n", rss_kib(), rss_frames,
                rss.size() > 2 ? rss.back() - rss[1] : 0L);
    if (r2) fs::remove(r2->path);
  }
  return 0;
}
