// Shareable stills at 4K: file size and encode time per format and setting, with the 16-bit
// PNG of the same frame as the peer measured in the same run (docs/performance.md). The frame
// is a real photograph (../shared/fixtures/exr/MtTamWest.exr, 1214x732) resampled bilinearly to
// 3840x2160 and encoded as hdr10 and sdr with the modes' defaults; each case is timed `rounds`
// times, the cases alternating within a round, and the median is reported.
//
//   bench_stills [--rounds N] [--threads N] [--exr PATH] [--only SUBSTRING]
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <functional>
#include <string>
#include <vector>

#include "encode/io/io.hpp"
#include "encode/io/stills.hpp"
#include "encode/pipeline.hpp"

namespace {

using namespace hdrd;
using Clock = std::chrono::steady_clock;

Image resample(const Image& src, int w, int h) {
  Image out(w, h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double sx = std::clamp((x + 0.5) * src.width / w - 0.5, 0.0, src.width - 1.0);
      const double sy = std::clamp((y + 0.5) * src.height / h - 0.5, 0.0, src.height - 1.0);
      const int x0 = static_cast<int>(sx), y0 = static_cast<int>(sy);
      const int x1 = std::min(x0 + 1, src.width - 1), y1 = std::min(y0 + 1, src.height - 1);
      const double fx = sx - x0, fy = sy - y0;
      for (int c = 0; c < 4; ++c)
        out.px(x, y)[c] = static_cast<float>((src.px(x0, y0)[c] * (1 - fx) + src.px(x1, y0)[c] * fx) * (1 - fy) +
                                             (src.px(x0, y1)[c] * (1 - fx) + src.px(x1, y1)[c] * fx) * fy);
    }
  return out;
}

EncodedFrame encode(const io::ExrImage& exr, const Image& img, Mode mode, int threads) {
  EncodeSettings s;
  s.target = default_target(mode);
  s.threads = threads;
  SceneInput in;
  in.image = &img;
  in.to_working = exr.to_working();
  auto f = encode_frame(in, s);
  if (!f) throw HdrdError(f.error());
  return std::move(*f);
}

struct Case {
  std::string name;
  std::function<std::size_t()> run;  // returns the file size
  std::vector<double> seconds{}, cpu_seconds{};
  std::size_t bytes = 0;
};

// CPU time of the whole process (all threads): what the encode costs on a shared machine,
// where wall time also counts the other jobs' turns.
double cpu_now() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + t.tv_nsec * 1e-9;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  int rounds = 3, threads = 2;
  std::string only;  // run the cases whose name contains this
  std::string exr_path = std::string(HDRD_SHARED_DIR_DEFAULT) + "/fixtures/exr/MtTamWest.exr";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--rounds") rounds = std::atoi(argv[i + 1]);
    else if (a == "--threads") threads = std::atoi(argv[i + 1]);
    else if (a == "--exr") exr_path = argv[i + 1];
    else if (a == "--only") only = argv[i + 1];
  }
  auto exr = io::read_exr(exr_path);
  if (!exr) {
    std::fprintf(stderr, "bench_stills: %s\n", exr.error().message.c_str());
    return 1;
  }
  const Image img = resample(exr->image, 3840, 2160);
  const auto t0 = Clock::now();
  const EncodedFrame hdr = encode(*exr, img, Mode::hdr10, threads);
  const auto t1 = Clock::now();
  const EncodedFrame sdr = encode(*exr, img, Mode::sdr, threads);
  std::printf("input %s resampled to 3840x2160; hdr10 encode_frame %.3f s, %d threads\n\n", exr_path.c_str(),
              std::chrono::duration<double>(t1 - t0).count(), threads);

  const auto size_of = [](auto&& r) {
    if (!r) throw HdrdError(r.error());
    return r->size();
  };
  io::AvifOptions avif;
  avif.threads = threads;
  io::AvifOptions avif_lossless = avif;
  avif_lossless.lossless = true;
  avif_lossless.speed = 7;  // the lossy default, for comparison; the lossless default is 9
  io::AvifOptions avif_fast = avif;
  avif_fast.speed = 9;
  io::AvifOptions avif_lossless_fast = avif_lossless;
  avif_lossless_fast.speed = 9;
  io::AvifOptions avif_444 = avif;
  avif_444.chroma = io::ChromaSubsampling::yuv444;
  io::JxlOptions jxl;
  jxl.threads = threads;
  io::JxlOptions jxl_lossless = jxl;
  jxl_lossless.lossless = true;
  io::GainMapOptions gm;
  io::GainMapOptions gm2 = gm;
  gm2.gain_map_scale = 2;
  io::GainMapOptions gm4_lum = gm;
  gm4_lum.gain_map_scale = 4;
  gm4_lum.channels = io::GainMapChannels::luminance;
  const auto gain = [&](const io::GainMapOptions& o) {
    auto r = io::encode_jpeg_gainmap(sdr, hdr, o);
    if (!r) throw HdrdError(r.error());
    return r->bytes.size();
  };
  std::vector<Case> cases{
      {"png (hdr10, 16-bit, the peer)", [&] { return size_of(io::encode_png(hdr)); }},
      {"avif q80 4:2:0 10-bit (default)", [&] { return size_of(io::encode_avif(hdr, avif)); }},
      {"avif q80 4:4:4 10-bit", [&] { return size_of(io::encode_avif(hdr, avif_444)); }},
      {"avif q80 4:2:0 10-bit speed 9", [&] { return size_of(io::encode_avif(hdr, avif_fast)); }},
      {"avif lossless (rgb, 10-bit) speed 7", [&] { return size_of(io::encode_avif(hdr, avif_lossless)); }},
      {"avif lossless (rgb, 10-bit) speed 9 (default)", [&] { return size_of(io::encode_avif(hdr, avif_lossless_fast)); }},
      {"jxl q90 (distance 1, effort 3, default)", [&] { return size_of(io::encode_jxl(hdr, jxl)); }},
      {"jxl lossless (16-bit, effort 3)", [&] { return size_of(io::encode_jxl(hdr, jxl_lossless)); }},
      {"jpeg sdr q90 (no gain map)", [&] { return size_of(io::encode_jpeg(sdr)); }},
      {"jpeg-gainmap rgb scale 1 (default)", [&] { return gain(gm); }},
      {"jpeg-gainmap rgb scale 2", [&] { return gain(gm2); }},
      {"jpeg-gainmap luminance scale 4", [&] { return gain(gm4_lum); }},
  };
  if (!only.empty())
    std::erase_if(cases, [&](const Case& c) { return c.name.find(only) == std::string::npos && c.name.find("png") != 0; });
  for (int r = 0; r < rounds; ++r)
    for (Case& c : cases) {
      const auto a = Clock::now();
      const double cpu = cpu_now();
      c.bytes = c.run();
      c.cpu_seconds.push_back(cpu_now() - cpu);
      c.seconds.push_back(std::chrono::duration<double>(Clock::now() - a).count());
    }
  const double png_cpu = median(cases[0].cpu_seconds);
  const double png_b = static_cast<double>(cases[0].bytes);
  std::printf("| format | size | vs PNG size | CPU s (median of %d) | vs PNG CPU | wall s |\n|---|---|---|---|---|---|\n",
              rounds);
  for (const Case& c : cases)
    std::printf("| %s | %.2f MB | %.3f | %.2f | %.2f | %.2f |\n", c.name.c_str(), c.bytes / 1e6, c.bytes / png_b,
                median(c.cpu_seconds), median(c.cpu_seconds) / png_cpu, median(c.seconds));
  return 0;
}
