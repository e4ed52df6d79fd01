// One pipeline behind every front end: the same request, said the same way and leaving the
// same things unsaid, gives the same frame through `hdrd render/encode/pattern`, the daemon
// (a curl-equivalent request over its socket), `hdrctl` and the Python client. Each case is
// written twice by hand, as a user would: CLI flags (hdrd and hdrctl take the same ones) and
// a JSON body (the daemon and the Python client). Compared: the raw DRM buffers (identical
// where both used the same encoder, else at most one code apart) and the sidecars' metadata.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "clients/cpp/client.hpp"
#include "tests/daemon/daemon_harness.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct Case {
  const char* name;
  const char* source;   // render, encode, pattern
  const char* flags;    // hdrd/hdrctl options
  const char* body;     // the same request as JSON
  const char* exr = ""; // encode: the fixture (../shared/fixtures/exr/...)
};

// Renders are small so that 4 front ends x the matrix stay within seconds on llvmpipe;
// several cases leave the size, the samples or the exposure to the defaults on purpose.
const Case kCases[] = {
    {"render_only_mode", "render", "--width 96 --height 54 --mode hdr10", R"({"width":96,"height":54,"display":{"mode":"hdr10"}})"},
    {"render_hdr_scene_levels", "render", "--scene hdr --width 96 --height 54 --samples 1 --paper-white 300 --peak 1500",
     R"({"scene":"hdr","width":96,"height":54,"samples":1,"display":{"paper_white_nits":300,"peak_nits":1500}})"},
    {"render_sdr", "render", "--width 80 --height 45 --mode sdr", R"({"width":80,"height":45,"display":{"mode":"sdr"}})"},
    {"render_hlg_exposure", "render", "--scene fresnel --width 64 --height 36 --mode hlg --exposure 1",
     R"({"scene":"fresnel","width":64,"height":36,"display":{"mode":"hlg"},"exposure":{"compensation_ev":1}})"},
    {"render_bt1886_ev100", "render", "--width 64 --height 36 --mode sdr-bt1886 --ev100 12",
     R"({"width":64,"height":36,"display":{"mode":"sdr-bt1886"},"exposure":{"ev100":12}})"},
    {"render_scrgb", "render", "--scene furnace --width 64 --height 36 --mode scrgb",
     R"({"scene":"furnace","width":64,"height":36,"display":{"mode":"scrgb"}})"},
    {"render_gltf", "render", "--scene ASSETS/MetalRoughSpheresNoTextures.glb --width 96 --height 54 --samples 2",
     R"({"scene":"MetalRoughSpheresNoTextures.glb","width":96,"height":54,"samples":2})"},
    {"render_bt2390_maxrgb", "render", "--width 64 --height 36 --peak 600 --tonemap bt2390 --tonemap-apply max-rgb",
     R"({"width":64,"height":36,"display":{"peak_nits":600},"tone":{"curve":"bt2390","apply":"max-rgb"}})"},
    {"render_histogram", "render",
     "--scene underwater --width 64 --height 36 --exposure-mode histogram --percentile 95 --percentile-target 0.5",
     R"({"scene":"underwater","width":64,"height":36,"exposure":{"mode":"histogram","percentile":95,"percentile_target":0.5}})"},
    {"render_camera", "render", "--width 64 --height 36 --camera 0,1.5,4:0,0.5,0:40",
     R"({"width":64,"height":36,"camera":{"position":[0,1.5,4],"target":[0,0.5,0],"fov_y_deg":40}})"},
    {"render_sdr_10bit_clip", "render", "--width 64 --height 36 --mode sdr --bits 10 --tonemap clip --gamut clip",
     R"({"width":64,"height":36,"display":{"mode":"sdr","bits":10},"tone":{"curve":"clip"},"gamut":"clip"})"},
    {"render_cpu_encoder", "render", "--width 64 --height 36 --encoder cpu --tonemap reinhard",
     R"({"width":64,"height":36,"encoder":"cpu","tone":{"curve":"reinhard"}})"},
    {"encode_defaults", "encode", "", R"({})", "Desk.exr"},
    {"encode_sdr_aces", "encode", "--mode sdr --tonemap aces-narkowicz --exposure -1",
     R"({"display":{"mode":"sdr"},"tone":{"curve":"aces-narkowicz"},"exposure_comp_ev":-1})", "Desk.exr"},
    {"encode_hlg_2000", "encode", "--mode hlg --peak 2000", R"({"display":{"mode":"hlg","peak_nits":2000}})", "MtTamWest.exr"},
    {"encode_scrgb", "encode", "--mode scrgb", R"({"display":{"mode":"scrgb"}})", "Rec709.exr"},
    {"encode_bt1886_narrow", "encode", "--mode sdr-bt1886 --black 0.05 --range narrow",
     R"({"display":{"mode":"sdr-bt1886","black_nits":0.05,"range":"narrow"}})", "Desk.exr"},
    {"encode_histogram_absolute", "encode", "--input absolute --exposure-mode histogram",
     R"({"input":"absolute","exposure":{"mode":"histogram"}})", "Tree.exr"},
    {"encode_reinhard_dither", "encode", "--tonemap reinhard --gamut clip --dither",
     R"({"tone":{"curve":"reinhard"},"gamut":"clip","dither":true})", "WideColorGamut.exr"},
    {"pattern_bt2111", "pattern", "bt2111 --width 192 --height 108", R"({"pattern":"bt2111","width":192,"height":108})"},
    {"pattern_window", "pattern", "window --width 96 --height 54 --level 600 --area 25",
     R"({"pattern":"window","width":96,"height":54,"params":{"level_nits":600,"area_percent":25}})"},
    {"pattern_ramp_sdr", "pattern", "pq-ramp --width 96 --height 54 --mode sdr --steps 5",
     R"({"pattern":"pq-ramp","width":96,"height":54,"display":{"mode":"sdr"},"params":{"steps":5}})"},
    {"pattern_near_black_hlg", "pattern", "near-black --width 96 --height 54 --mode hlg",
     R"({"pattern":"near-black","width":96,"height":54,"display":{"mode":"hlg"}})"},
};

// "ASSETS/x" in a case's flags: the file in the daemon's asset root. The CLI names it by its
// path; hdrctl, like the JSON body, by its name inside the root.
std::string replace_assets(std::string s, const std::string& prefix) {
  for (std::size_t at; (at = s.find("ASSETS/")) != std::string::npos;) s.replace(at, 7, prefix);
  return s;
}

std::vector<std::uint8_t> read_bytes(const fs::path& p) {
  const std::string s = read_file(p);
  return {s.begin(), s.end()};
}

// The largest per-channel code difference of two scan-out buffers of the same format.
int max_code_difference(const std::vector<std::uint8_t>& a, const std::vector<std::uint8_t>& b, const std::string& fourcc) {
  if (a.size() != b.size()) return 1 << 20;
  int worst = 0;
  for (std::size_t i = 0; i + 4 <= a.size(); i += 4) {
    std::uint32_t x, y;
    std::memcpy(&x, &a[i], 4);
    std::memcpy(&y, &b[i], 4);
    if (fourcc == "XB30") {
      for (int c = 0; c < 3; ++c)
        worst = std::max(worst, std::abs(int((x >> (10 * c)) & 1023) - int((y >> (10 * c)) & 1023)));
    } else if (fourcc == "XR24") {
      for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(int((x >> (8 * c)) & 255) - int((y >> (8 * c)) & 255)));
    } else {  // AB4H: half floats; count differing bit patterns as ULPs
      for (int c = 0; c < 2; ++c)
        worst = std::max(worst, std::abs(int((x >> (16 * c)) & 0xffff) - int((y >> (16 * c)) & 0xffff)));
    }
  }
  return worst;
}

struct Outcome {
  json sidecar;
  std::vector<std::uint8_t> raw;
};

// What the sidecars must agree on.
json essentials(const json& s) {
  json e = {{"mode", s["mode"]},
            {"fourcc", s["fourcc"]},
            {"width", s["width"]},
            {"height", s["height"]},
            {"range", s["range"]},
            {"bits", s["bits"]},
            {"peak_nits", s["peak_nits"]},
            {"black_nits", s["black_nits"]},
            {"paper_white_nits", s["paper_white_nits"]},
            {"ui_white_nits", s["ui_white_nits"]},
            {"target_source", s["target_source"]},
            {"max_cll_nits", s["content_light_level"]["max_cll_nits"]},
            {"max_fall_nits", s["content_light_level"]["max_fall_nits"]}};
  const auto& st = s["settings"];
  if (st.contains("tone_curve")) e["tone_curve"] = {st["tone_curve"]["name"], st["tone_curve"]["apply"]};
  if (st.contains("exposure")) e["exposure"] = {st["exposure"]["mode"], st["exposure"]["scale"]};
  if (st.contains("render")) e["encoder"] = st["render"]["encoder"];
  return e;
}

class FrontEnds : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    daemon_ = new DaemonProcess();
    ASSERT_TRUE(daemon_->ready()) << daemon_->log();
    if (auto gltf = fixture("fixtures/gltf/MetalRoughSpheresNoTextures/MetalRoughSpheresNoTextures.glb"))
      fs::copy_file(*gltf, daemon_->assets() / "MetalRoughSpheresNoTextures.glb");
  }
  static void TearDownTestSuite() {
    delete daemon_;
    daemon_ = nullptr;
  }

  Outcome cli(const Case& c, const fs::path& exr) {
    const fs::path out = dir_ / (std::string("cli-") + c.name);
    const std::string cmd = fmt::format("{} {} {} {} -o {} --format raw -q", hdrd_binary().string(), c.source,
                                        exr.empty() ? "" : exr.string(), replace_assets(c.flags, daemon_->assets().string() + "/"),
                                        out.string());
    auto r = run_command(cmd);
    EXPECT_EQ(r.exit_code, 0) << cmd << "\n" << r.err;
    return {json::parse(read_file(out.string() + ".json"), nullptr, false), read_bytes(out.string() + ".raw")};
  }

  Outcome from_dump(const json& sidecar) {
    if (!sidecar.is_object() || !sidecar.contains("files")) return {sidecar, {}};
    return {sidecar, read_bytes(sidecar["files"]["raw"].get<std::string>())};
  }

  // A curl-equivalent request: the JSON body plus "dump": true and the raw format.
  Outcome daemon(const Case& c, const fs::path& exr) {
    json body = json::parse(c.body);
    body["dump"] = true;
    body["formats"] = {"raw"};
    body["name"] = std::string("daemon-") + c.name;
    auto client = daemon_->client();
    Result<daemon::ClientResponse> r = make_error("x", "x");
    if (std::string(c.source) == "encode") {
      std::string ct;
      const std::string mp = daemon::multipart_body(
          {{"image", exr.filename().string(), "image/x-exr", read_file(exr)}, {"request", "", "application/json", body.dump()}},
          &ct);
      r = client.request("POST", "/v1/encode", mp, {{"Content-Type", ct}, {"Accept", "application/json"}});
    } else {
      r = client.request("POST", std::string("/v1/") + c.source, body.dump(),
                         {{"Content-Type", "application/json"}, {"Accept", "application/json"}});
    }
    EXPECT_TRUE(r.ok());
    if (!r.ok()) return {};
    EXPECT_EQ(r->status, 200) << r->body;
    return from_dump(json::parse(r->body, nullptr, false));
  }

  Outcome hdrctl(const Case& c, const fs::path& exr) {
    const std::string flags = replace_assets(c.flags, "");
    const std::string cmd = fmt::format("{} --socket {} --json -q {} {} {} --dump --format raw --name ctl-{}",
                                        (binary_dir() / "tools/hdrctl/hdrctl").string(), daemon_->socket().string(),
                                        c.source, exr.empty() ? "" : exr.string(), flags, c.name);
    auto r = run_command(cmd);
    EXPECT_EQ(r.exit_code, 0) << cmd << "\n" << r.err;
    return from_dump(json::parse(r.out, nullptr, false));
  }

  static DaemonProcess* daemon_;
  TempDir dir_;
};
DaemonProcess* FrontEnds::daemon_ = nullptr;

// The Python client runs every case in one process (the standard library client of
// clients/python), writing each case's sidecar to stdout as one JSON object per line.
std::map<std::string, json> python_outcomes(const DaemonProcess& d, const std::vector<std::pair<const Case*, fs::path>>& cases,
                                            const fs::path& dir) {
  json list = json::array();
  for (const auto& [c, exr] : cases) {
    json body = json::parse(c->body);
    body["dump"] = true;
    body["formats"] = {"raw"};
    body["name"] = std::string("py-") + c->name;
    list.push_back({{"name", c->name}, {"source", c->source}, {"body", body}, {"exr", exr.string()}});
  }
  std::ofstream(dir / "cases.json") << list.dump();
  std::ofstream(dir / "run.py") << R"(import json, sys
sys.path.insert(0, sys.argv[1])
from hdrd_client import HdrdClient
c = HdrdClient(sys.argv[2])
for case in json.load(open(sys.argv[3])):
    b = case["body"]
    if case["source"] == "render":
        s = c.render(b)
    elif case["source"] == "encode":
        s = c.encode(open(case["exr"], "rb").read(), b)
    else:
        p = b.pop("pattern")
        s = c.pattern(p, **b)
    print(json.dumps({"name": case["name"], "sidecar": s}))
)";
  auto r = run_command(fmt::format("python3 {} {} {} {}", (dir / "run.py").string(),
                                   (source_dir() / "clients/python").string(), d.socket().string(),
                                   (dir / "cases.json").string()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  std::map<std::string, json> out;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    const json j = json::parse(line, nullptr, false);
    if (j.is_object()) out[j["name"]] = j["sidecar"];
  }
  return out;
}

TEST_F(FrontEnds, SameRequestSameFrameEverywhere) {
  ASSERT_GE(std::size(kCases), 20u);
  std::vector<std::pair<const Case*, fs::path>> runnable;
  for (const auto& c : kCases) {
    fs::path exr;
    if (*c.exr) {
      auto f = fixture(std::string("fixtures/exr/") + c.exr);
      if (!f) continue;  // counted below: the whole matrix needs ../shared
      exr = *f;
    }
    if (std::string(c.name) == "render_gltf" && !fs::exists(daemon_->assets() / "MetalRoughSpheresNoTextures.glb"))
      continue;
    runnable.emplace_back(&c, exr);
  }
  if (runnable.size() < std::size(kCases)) GTEST_SKIP() << "shared fixtures missing: ../shared/fixtures (EXR, glTF)";
  const auto py = python_outcomes(*daemon_, runnable, dir_.path());
  for (const auto& [c, exr] : runnable) {
    SCOPED_TRACE(c->name);
    const Outcome a = cli(*c, exr), b = daemon(*c, exr), h = hdrctl(*c, exr);
    Outcome p;
    if (py.count(c->name)) p = from_dump(py.at(c->name));
    ASSERT_TRUE(a.sidecar.is_object() && b.sidecar.is_object() && h.sidecar.is_object() && p.sidecar.is_object());
    const json want = essentials(a.sidecar);
    const std::string fourcc = a.sidecar["fourcc"];
    for (const auto& [who, o] : {std::pair{"daemon", &b}, {"hdrctl", &h}, {"python", &p}}) {
      EXPECT_EQ(essentials(o->sidecar), want) << who << " vs hdrd " << c->source;
      const int diff = max_code_difference(a.raw, o->raw, fourcc);
      const bool same_encoder = essentials(o->sidecar).value("encoder", "") == want.value("encoder", "");
      EXPECT_LE(diff, same_encoder ? 0 : 1) << who << ": codes differ by " << diff;
    }
  }
}

// hdrctl -o FILE: the extension names the format by job/outputs' one table (before issue 29,
// .jpg and every unknown extension silently gave a PNG). Oracles: each file's own magic
// bytes (ISO/IEC 10918-1 SOI, the PNG signature, the EXR magic) and the exit status.
TEST_F(FrontEnds, HdrctlOutputExtensionPicksTheFormat) {
  const std::string base = fmt::format("{} --socket {} -q pattern window --width 64 --height 36 ",
                                       (binary_dir() / "tools/hdrctl/hdrctl").string(), daemon_->socket().string());
  struct Want {
    const char* file;
    const char* mode;
    std::string magic;
  };
  const std::string jpeg_soi = "\xFF\xD8\xFF", png_sig = "\x89PNG\r\n\x1A\n", exr_magic = "\x76\x2F\x31\x01";
  const Want wants[] = {{"f.jpg", "sdr", jpeg_soi},   {"f.jpeg", "sdr", jpeg_soi}, {"F.JPG", "sdr", jpeg_soi},
                        {"f.png", "hdr10", png_sig}, {"f.exr", "scrgb", exr_magic}};
  for (const auto& w : wants) {
    const fs::path out = dir_ / w.file;
    const auto r = run_command(base + "--mode " + w.mode + " -o " + out.string());
    ASSERT_EQ(r.exit_code, 0) << w.file << ": " << r.err;
    EXPECT_EQ(read_file(out).substr(0, w.magic.size()), w.magic) << w.file;
  }
  // An extension no format is written as: exit 2, nothing written, the known ones named.
  const auto r = run_command(base + "--mode sdr -o " + (dir_ / "f.heic").string());
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "f.heic"));
  for (const char* known : {".png", ".exr", ".raw", ".avif", ".jxl", ".jpg", ".jpeg"})
    EXPECT_NE(r.err.find(known), std::string::npos) << known << " not named in: " << r.err;
  // --format's help names every format a reply can be.
  const auto help = run_command(fmt::format("{} render --help", (binary_dir() / "tools/hdrctl/hdrctl").string()));
  for (const char* f : {"png", "exr", "raw", "avif", "jxl", "jpeg", "jpeg-gainmap"})
    EXPECT_NE(help.out.find(f), std::string::npos) << f;
  const auto fpos = help.out.find("--format");
  ASSERT_NE(fpos, std::string::npos);
  EXPECT_NE(help.out.find("jpeg-gainmap", fpos), std::string::npos) << help.out.substr(fpos, 400);
}

}  // namespace
}  // namespace hdrd::testing
