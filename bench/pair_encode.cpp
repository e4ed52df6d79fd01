// Times two or more builds of the encode library in one process, frame by frame in turn,
// on bench_encode's 4K frame (HDR10, the default curve, +0.5 EV). On a machine whose speed
// drifts between seconds (this project's VM: +-30 %), separate benchmark processes cannot
// resolve a few per cent; alternating builds inside one process can, because each pair of
// frames runs under the same conditions. bench/compare-builds.sh builds the libraries from
// git revisions and runs this.
//
//   pair_encode [--threads N] [--rounds N] [--ui] A.so B.so [C.so ...]
//
// Each library is a shared build of hdrd_encode whose public headers (encode/pipeline.hpp
// and what it includes) match this driver's: the frame and settings cross the boundary.
// Prints, per library, the median time per frame and the median ratio of its time to the
// first library's in the same round, and whether its output bytes equal the first's.
#include <dlfcn.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "bench/encode_inputs.hpp"
#include "encode/pipeline.hpp"

using namespace hdrd;

namespace {

using PrepareFn = Result<PreparedPipeline> (*)(const SceneInput&, const EncodeSettings&);
using EncodeFn = Result<void> (*)(const SceneInput&, const PreparedPipeline&, EncodedFrame&);

struct Library {
  std::string path;
  PrepareFn prepare = nullptr;
  EncodeFn encode = nullptr;
  std::vector<double> ms, ratio;
  EncodedFrame frame;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"Time builds of the encode library against each other in one process"};
  int threads = 2, rounds = 20;
  bool ui = false;
  std::vector<std::string> paths;
  app.add_option("--threads", threads, "encoder threads")->check(CLI::Range(1, 64));
  app.add_option("--rounds", rounds, "paired rounds (after two warm-up rounds)")->check(CLI::Range(1, 10000));
  app.add_flag("--ui", ui, "composite bench_encode's 1200x300 UI overlay");
  app.add_option("libraries", paths, "shared builds of hdrd_encode; the first is the baseline")->required()->expected(2, -1);
  CLI11_PARSE(app, argc, argv);

  std::vector<Library> libs;
  for (const auto& p : paths) {
    // RTLD_DEEPBIND: each library resolves its own symbols first, so two builds coexist.
    void* h = dlopen(p.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_DEEPBIND);
    if (!h) {
      std::fprintf(stderr, "pair_encode: cannot load %s: %s\n", p.c_str(), dlerror());
      return 1;
    }
    Library l;
    l.path = p;
    l.prepare = reinterpret_cast<PrepareFn>(dlsym(h, "_ZN4hdrd16prepare_pipelineERKNS_10SceneInputERKNS_14EncodeSettingsE"));
    l.encode = reinterpret_cast<EncodeFn>(
        dlsym(h, "_ZN4hdrd20encode_prepared_intoERKNS_10SceneInputERKNS_16PreparedPipelineERNS_12EncodedFrameE"));
    if (!l.prepare || !l.encode) {
      std::fprintf(stderr, "pair_encode: %s has no hdrd::prepare_pipeline / encode_prepared_into\n", p.c_str());
      return 1;
    }
    libs.push_back(std::move(l));
  }

  SceneInput in;
  in.half = &bench::frame_half();
  EncodeSettings s = bench::settings_for(Mode::hdr10, threads);
  if (ui) bench::add_ui_overlay(s);

  const int n = static_cast<int>(libs.size());
  for (int r = -2; r < rounds; ++r) {
    std::vector<double> t(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) {
      const int v = (r & 1) ? n - 1 - k : k;  // alternate the order: no library always goes first
      auto& l = libs[static_cast<std::size_t>(v)];
      const auto t0 = std::chrono::steady_clock::now();
      auto p = l.prepare(in, s);
      if (!p || !l.encode(in, *p, l.frame)) {
        std::fprintf(stderr, "pair_encode: %s failed to encode\n", l.path.c_str());
        return 1;
      }
      t[static_cast<std::size_t>(v)] = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    }
    if (r < 0) continue;
    for (int v = 0; v < n; ++v) {
      libs[static_cast<std::size_t>(v)].ms.push_back(t[static_cast<std::size_t>(v)]);
      libs[static_cast<std::size_t>(v)].ratio.push_back(t[static_cast<std::size_t>(v)] / t[0]);
    }
    std::fprintf(stderr, "\rround %d/%d", r + 1, rounds);
  }
  std::fprintf(stderr, "\n");
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  auto quartile = [](std::vector<double> v, int q) {
    std::sort(v.begin(), v.end());
    return v[v.size() * static_cast<std::size_t>(q) / 4];
  };
  std::printf("%d threads, %d rounds%s\n", threads, rounds, ui ? ", UI overlay" : "");
  for (const auto& l : libs)
    std::printf("%-40s median %7.2f ms | vs first: median %.3fx (quartiles %.3f .. %.3f) | output %s\n", l.path.c_str(),
                median(l.ms), median(l.ratio), quartile(l.ratio, 1), quartile(l.ratio, 3),
                l.frame.data == libs[0].frame.data ? "identical" : "DIFFERS");
  return 0;
}
