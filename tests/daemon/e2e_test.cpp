// End to end: the real `hdrd serve` on a temporary socket, driven by curl, hdrctl, the
// Python client and raw sockets. Frames are small (64x36 .. 256x144) to keep this fast.
// Oracles: the PNG and H.273 specifications (IHDR, cICP bytes), the in-process encoder
// for /v1/encode (same bytes as a library call), properties (distinct requests give
// distinct, self-consistent frames; an identity LUT changes nothing).
#include <gtest/gtest.h>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/stat.h>

#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <regex>
#include <set>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "encode/colour/transfer.hpp"
#include "tests/daemon/daemon_harness.hpp"

namespace hdrd::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using daemon::ClientResponse;

#define REQUIRE_DAEMON(d) \
  ASSERT_TRUE((d).ready()) << "hdrd serve did not come up; its log:\n" << (d).log()

ClientResponse post(daemon::Client& c, const std::string& path, const std::string& body,
                    const std::string& accept = "image/png", const std::string& type = "application/json") {
  auto r = c.request("POST", path, body, {{"Content-Type", type}, {"Accept", accept}});
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? *r : ClientResponse{};
}

ClientResponse get(daemon::Client& c, const std::string& path) {
  auto r = c.request("GET", path);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? *r : ClientResponse{};
}

std::string error_code(const ClientResponse& r) {
  auto j = json::parse(r.body, nullptr, false);
  return j.is_object() && j.contains("error") ? j["error"].value("code", "") : "(not a JSON error: " + r.body.substr(0, 80) + ")";
}

// PNG (ISO/IEC 15948 §11.2.2): signature, then IHDR with big-endian width and height.
struct PngHeader {
  bool ok = false;
  std::uint32_t width = 0, height = 0;
  int bit_depth = 0;
  std::string cicp;  // the 4 payload bytes of a cICP chunk, if any
};
PngHeader png_header(const std::string& b) {
  PngHeader h;
  static const std::string sig("\x89PNG\r\n\x1a\n", 8);
  if (b.size() < 33 || b.compare(0, 8, sig) != 0 || b.compare(12, 4, "IHDR") != 0) return h;
  auto be32 = [&](std::size_t o) {
    return std::uint32_t((unsigned char)b[o]) << 24 | std::uint32_t((unsigned char)b[o + 1]) << 16 |
           std::uint32_t((unsigned char)b[o + 2]) << 8 | std::uint32_t((unsigned char)b[o + 3]);
  };
  h.ok = true;
  h.width = be32(16);
  h.height = be32(20);
  h.bit_depth = (unsigned char)b[24];
  for (std::size_t o = 8; o + 12 <= b.size();) {
    const std::uint32_t len = be32(o);
    if (b.compare(o + 4, 4, "cICP") == 0 && len == 4) h.cicp = b.substr(o + 8, 4);
    if (b.compare(o + 4, 4, "IDAT") == 0) break;
    o += 12 + len;
  }
  return h;
}

std::string render_body(int w, int h, const std::string& extra = "") {
  // One sample, as the daemon tests were sized for (the table's default is 4x MSAA).
  return fmt::format(R"({{"width":{},"height":{},"samples":1{}}})", w, h, extra.empty() ? "" : "," + extra);
}

double metric(const std::string& text, const std::string& name) {
  std::smatch m;
  const std::regex re("(^|\\n)" + name + " ([0-9.e+-]+)");
  return std::regex_search(text, m, re) ? std::stod(m[2]) : -1;
}

// Waits until the daemon has no admitted job left (after cancellations or drains).
void wait_idle(const DaemonProcess& d) {
  auto c = d.client();
  for (int i = 0; i < 600; ++i) {
    auto s = get(c, "/v1/status");
    auto j = json::parse(s.body, nullptr, false);
    if (j.is_object() && j["queue"]["admitted"] == 0) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

// ---- the issue's example -------------------------------------------------------------

TEST(DaemonE2E, IssueCurlCommandRendersAnHdr10Png) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  const fs::path out = d.dir() / "frame.png";
  const std::string sock = d.socket().string();
  auto r = run_command("SOCK='" + sock + "' && cd '" + d.dir().string() +
                       "' && curl -sS --fail --unix-socket \"$SOCK\" -H 'Accept: image/png' -H 'Content-Type: "
                       "application/json' -d '{\"width\":256,\"height\":144,\"display\":{\"mode\":\"hdr10\",\"peak_"
                       "nits\":1000}}' http://localhost/v1/render -o frame.png");
  ASSERT_EQ(r.exit_code, 0) << r.err << "\n" << d.log();
  const auto h = png_header(read_file(out));
  ASSERT_TRUE(h.ok);
  EXPECT_EQ(h.width, 256u);
  EXPECT_EQ(h.height, 144u);
  EXPECT_EQ(h.bit_depth, 16);
  // H.273: primaries 9 (BT.2020), transfer 16 (PQ), matrix 0 (RGB), full range 1.
  EXPECT_EQ(h.cicp, std::string("\x09\x10\x00\x01", 4));

  // The same body with a syntax error: 400 and the JSON error.
  r = run_command("curl -s --unix-socket '" + sock + "' -o '" + (d.dir() / "err.json").string() +
                  "' -w '%{http_code}' -H 'Accept: image/png' -H 'Content-Type: application/json' -d "
                  "'{\"width\":256,\"height\":144,\"display\":{\"mode\":\"hdr10\",\"peak_nits\":1000}' "
                  "http://localhost/v1/render");
  EXPECT_EQ(r.out, "400");
  const auto err = json::parse(read_file(d.dir() / "err.json"), nullptr, false);
  ASSERT_TRUE(err.is_object());
  EXPECT_EQ(err["error"]["code"], "request.syntax");
  EXPECT_FALSE(err["error"]["message"].get<std::string>().empty());
}

// ---- every endpoint ----------------------------------------------------------------------

TEST(DaemonE2E, GetEndpoints) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  auto s = get(c, "/v1/status");
  ASSERT_EQ(s.status, 200);
  auto j = json::parse(s.body);
  EXPECT_EQ(j["service"], "hdrd");
  EXPECT_TRUE(j.contains("version") && j.contains("uptime_s") && j.contains("queue") && j.contains("workers"));
  EXPECT_TRUE(j["renderer"].contains("available"));

  auto caps = get(c, "/v1/capabilities");
  ASSERT_EQ(caps.status, 200);
  j = json::parse(caps.body);
  std::set<std::string> modes;
  for (const auto& m : j["modes"]) modes.insert(m["name"]);
  EXPECT_EQ(modes, (std::set<std::string>{"hdr10", "hlg", "scrgb", "sdr", "sdr-bt1886"})) << "REFERENCE.md §1.9 names";
  std::set<std::string> curves;
  for (const auto& cv : j["tone_curves"]) {
    curves.insert(cv["name"]);
    for (const auto& p : cv["params"]) {
      EXPECT_LE(p["min"].get<double>(), p["default"].get<double>()) << cv["name"] << "." << p["name"];
      EXPECT_LE(p["default"].get<double>(), p["max"].get<double>()) << cv["name"] << "." << p["name"];
    }
  }
  EXPECT_TRUE(curves.count("clip")) << "REFERENCE.md §1.3 defines `clip`";
  EXPECT_GT(j["limits"]["max_width"].get<int>(), 0);
  std::set<std::string> patterns;
  for (const auto& p : j["patterns"]) patterns.insert(p["name"]);
  EXPECT_EQ(patterns, (std::set<std::string>{"bt2111", "pq-ramp", "window", "near-black", "clipping", "sdr-grey",
                                             "sdr-shadows"}))
      << "issue 7's patterns and issue 15's sdr-shadows";

  auto disp = get(c, "/v1/displays");
  ASSERT_EQ(disp.status, 200) << disp.body;
  EXPECT_TRUE(json::parse(disp.body).is_object());

  auto head = c.request("HEAD", "/v1/status");
  ASSERT_TRUE(head.ok());
  EXPECT_EQ(head->status, 200);
  EXPECT_TRUE(head->body.empty());

  auto m = get(c, "/metrics");
  ASSERT_EQ(m.status, 200);
  ASSERT_NE(m.header("content-type"), nullptr);
  EXPECT_EQ(m.header("content-type")->rfind("text/plain", 0), 0u);
  // Prometheus text exposition format 0.0.4: comments, or "name{labels} value".
  const std::regex sample(R"(^[a-zA-Z_:][a-zA-Z0-9_:]*(\{[a-zA-Z_][a-zA-Z0-9_]*="[^"]*"(,[a-zA-Z_][a-zA-Z0-9_]*="[^"]*")*\})? [-+0-9.eE]+(Inf)?$)");
  std::istringstream lines(m.body);
  int samples = 0;
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    EXPECT_TRUE(std::regex_match(line, sample)) << line;
    ++samples;
  }
  EXPECT_GT(samples, 10);
  EXPECT_NE(m.body.find("hdrd_requests_total{endpoint=\"/v1/status\",status=\"200\"}"), std::string::npos);
}

TEST(DaemonE2E, RenderInEveryResponseFormat) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  auto raw = post(c, "/v1/render", render_body(64, 36, R"("display":{"mode":"hdr10","peak_nits":600})"),
                  "application/octet-stream");
  ASSERT_EQ(raw.status, 200) << raw.body;
  EXPECT_EQ(*raw.header("x-hdrd-fourcc"), "XB30");
  EXPECT_EQ(*raw.header("x-hdrd-width"), "64");
  EXPECT_EQ(*raw.header("x-hdrd-height"), "36");
  EXPECT_EQ(*raw.header("x-hdrd-peak-nits"), "600");
  const std::size_t stride = std::stoul(*raw.header("x-hdrd-stride"));
  EXPECT_GE(stride, 64u * 4);
  EXPECT_EQ(raw.body.size(), stride * 36);
  EXPECT_LE(std::stod(*raw.header("x-hdrd-maxcll")), 600.0 + 1) << "content never exceeds the target peak";

  auto exr = post(c, "/v1/render", render_body(64, 36), "image/x-exr");
  ASSERT_EQ(exr.status, 200) << exr.body;
  auto decoded = io::read_exr_memory({reinterpret_cast<const std::uint8_t*>(exr.body.data()), exr.body.size()});
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  EXPECT_EQ(decoded->image.width, 64);
  EXPECT_EQ(decoded->image.height, 36);
  ASSERT_TRUE(decoded->white_luminance.has_value());
  EXPECT_DOUBLE_EQ(*decoded->white_luminance, 203.0);

  // scrgb has no PNG form: EXR by default, 406 when only PNG is acceptable.
  auto scrgb = post(c, "/v1/render", render_body(64, 36, R"("display":{"mode":"scrgb"})"), "*/*");
  ASSERT_EQ(scrgb.status, 200);
  EXPECT_EQ(*scrgb.header("content-type"), "image/x-exr");
  EXPECT_EQ(*scrgb.header("x-hdrd-fourcc"), "AB4H");
  auto no_png = post(c, "/v1/render", render_body(64, 36, R"("display":{"mode":"scrgb"})"), "image/png");
  EXPECT_EQ(no_png.status, 406);

  auto sdr = post(c, "/v1/render", render_body(64, 36, R"("display":{"mode":"sdr"})"));
  ASSERT_EQ(sdr.status, 200);
  EXPECT_EQ(png_header(sdr.body).bit_depth, 8);
  EXPECT_EQ(*sdr.header("x-hdrd-fourcc"), "XR24");
}

// An EXR made here, encoded by the daemon and by the library in-process: same bytes.
TEST(DaemonE2E, EncodeUploadMatchesTheInProcessEncoder) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  Image img(48, 24);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x) {
      float* p = img.px(x, y);
      p[0] = 0.02f * x * (1 + y % 3);
      p[1] = 0.01f * (x + y);
      p[2] = 0.5f * std::sin(0.2f * x) + 0.6f;
      p[3] = 1;
    }
  io::ExrWriteOptions wo;
  wo.half = false;
  auto bytes = io::encode_exr(img, wo);
  ASSERT_TRUE(bytes.ok());
  const std::string body(bytes->begin(), bytes->end());
  auto c = d.client();
  auto r = post(c, "/v1/encode?mode=hdr10&peak_nits=600&curve=clip", body, "application/octet-stream", "image/x-exr");
  ASSERT_EQ(r.status, 200) << r.body;

  auto exr = io::read_exr_memory(*bytes);
  ASSERT_TRUE(exr.ok());
  SceneInput in;
  in.image = &exr->image;
  in.to_working = exr->to_working();
  EncodeSettings s;
  s.target = default_target(Mode::hdr10);
  s.target.peak_nits = 600;
  s.tone.curve = "clip";
  auto frame = encode_frame(in, s);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  ASSERT_EQ(r.body.size(), frame->data.size());
  EXPECT_TRUE(std::equal(frame->data.begin(), frame->data.end(), reinterpret_cast<const std::uint8_t*>(r.body.data())));

  // The same upload as multipart (curl -F) with the options as a JSON part.
  fs::path f = d.dir() / "in.exr";
  std::ofstream(f, std::ios::binary) << body;
  const fs::path out = d.dir() / "out.raw";
  auto cr = run_command("curl -sS --fail --unix-socket '" + d.socket().string() + "' -H 'Accept: application/octet-stream' -F image=@" +
                        f.string() + " -F 'request={\"display\":{\"mode\":\"hdr10\",\"peak_nits\":600},\"tone\":{\"curve\":\"clip\"}};type=application/json' http://localhost/v1/encode -o " +
                        out.string());
  ASSERT_EQ(cr.exit_code, 0) << cr.err;
  EXPECT_EQ(read_file(out), r.body);

  auto bad = post(c, "/v1/encode", "this is not an EXR", "image/png", "image/x-exr");
  EXPECT_EQ(bad.status, 422);
  EXPECT_EQ(error_code(bad).rfind("exr.", 0), 0u) << error_code(bad);
}

TEST(DaemonE2E, DumpsLandAtomicallyInTheDumpDirectory) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  auto r = post(c, "/v1/render", render_body(64, 36, R"("dump":true,"name":"frame1","formats":["png","raw"])"),
                "application/json");
  ASSERT_EQ(r.status, 200) << r.body;
  const auto j = json::parse(r.body);
  std::set<std::string> expected, present;
  for (const auto& [k, v] : j["files"].items()) {
    const fs::path p = v.get<std::string>();
    EXPECT_EQ(fs::canonical(p.parent_path()), fs::canonical(d.dumps())) << p;
    EXPECT_TRUE(fs::is_regular_file(p)) << p;
    expected.insert(p.filename().string());
  }
  for (const auto& e : fs::directory_iterator(d.dumps())) present.insert(e.path().filename().string());
  EXPECT_EQ(present, expected) << "no temporary or partial files are left";
  EXPECT_TRUE(expected.count("frame1.png") && expected.count("frame1.raw"));
  EXPECT_EQ(fs::file_size(d.dumps() / "frame1.raw"), j["stride_bytes"].get<std::size_t>() * 36);

  auto evil = post(c, "/v1/render", render_body(64, 36, R"("dump":true,"name":"../../evil")"), "application/json");
  EXPECT_EQ(evil.status, 400);
  EXPECT_FALSE(fs::exists(d.dir() / "evil.png"));
}

// ---- concurrency -------------------------------------------------------------------------

TEST(DaemonE2E, SixteenConcurrentClientsGetCorrectDistinctResults) {
  DaemonProcess d("[workers]\nrender_workers = 2\nencode_threads = 2\n");
  REQUIRE_DAEMON(d);
  constexpr int kClients = 16;
  auto body = [](int i) {
    return render_body(48 + 4 * i, 27, fmt::format(R"("exposure_comp_ev":{})", -2.0 + 0.25 * i));
  };
  std::vector<ClientResponse> results(kClients);
  std::vector<std::thread> threads;
  for (int i = 0; i < kClients; ++i)
    threads.emplace_back([&, i] {
      auto c = d.client();
      results[std::size_t(i)] = post(c, "/v1/render", body(i));
    });
  for (auto& t : threads) t.join();
  std::set<std::string> distinct;
  auto c = d.client();
  for (int i = 0; i < kClients; ++i) {
    const auto& r = results[std::size_t(i)];
    ASSERT_EQ(r.status, 200) << i << ": " << r.body;
    const auto h = png_header(r.body);
    EXPECT_EQ(h.width, std::uint32_t(48 + 4 * i)) << i;
    EXPECT_EQ(*r.header("x-hdrd-width"), std::to_string(48 + 4 * i));
    distinct.insert(r.body);
    // Each answer is the frame its own request produces (no mix-ups between clients).
    auto again = post(c, "/v1/render", body(i));
    EXPECT_EQ(again.body, r.body) << "client " << i;
  }
  EXPECT_EQ(distinct.size(), std::size_t(kClients));
}

TEST(DaemonE2E, IdenticalConcurrentRequestsShareOneJob) {
  DaemonProcess d("[workers]\nrender_workers = 1\n");
  REQUIRE_DAEMON(d);
  // Keep the only render worker busy, so that the identical requests all meet in the queue.
  std::thread blocker([&] {
    auto c = d.client();
    post(c, "/v1/render", render_body(1920, 1080, R"("exposure_comp_ev":0.5)"));
  });
  auto c = d.client();
  for (int i = 0; i < 200; ++i) {
    auto s = json::parse(get(c, "/v1/status").body);
    if (s["queue"]["running"].get<int>() >= 1) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  std::vector<ClientResponse> results(4);
  std::vector<std::thread> threads;
  for (int i = 0; i < 4; ++i)
    threads.emplace_back([&, i] {
      auto cc = d.client();
      results[std::size_t(i)] = post(cc, "/v1/render", render_body(96, 54));
    });
  for (auto& t : threads) t.join();
  blocker.join();
  int coalesced = 0;
  for (const auto& r : results) {
    ASSERT_EQ(r.status, 200);
    EXPECT_EQ(r.body, results[0].body);
    coalesced += r.header("x-hdrd-coalesced") ? 1 : 0;
  }
  EXPECT_EQ(coalesced, 3) << "one job, three requests joined it";
}

TEST(DaemonE2E, FullQueueAnswers503WithRetryAfter) {
  DaemonProcess d("[workers]\nrender_workers = 1\nencode_threads = 1\nqueue_depth = 0\ncoalesce = false\n"
                  "retry_after_s = 3\n");
  REQUIRE_DAEMON(d);
  std::vector<ClientResponse> results(6);
  std::vector<std::thread> threads;
  for (int i = 0; i < 6; ++i)
    threads.emplace_back([&, i] {
      auto c = d.client();
      results[std::size_t(i)] = post(c, "/v1/render", render_body(1280 + 8 * i, 720));
    });
  for (auto& t : threads) t.join();
  int ok = 0, full = 0;
  for (const auto& r : results) {
    if (r.status == 200) ++ok;
    if (r.status == 503) {
      ++full;
      EXPECT_EQ(error_code(r), "queue.full");
      ASSERT_NE(r.header("retry-after"), nullptr);
      EXPECT_EQ(*r.header("retry-after"), "3");
    }
  }
  EXPECT_GE(ok, 1);
  EXPECT_GE(full, 1) << "capacity is 2 (1 render worker + 1 encode thread + 0 queue)";
  EXPECT_EQ(ok + full, 6);
}

// ---- malformed requests: each gets the right error and the daemon keeps serving ------------

struct Malformed {
  const char* name;
  std::string method, path, content_type, accept, body;
  int status;
  std::string code;
};

TEST(DaemonE2E, MalformedRequestsGetTheRightErrors) {
  DaemonProcess d("[limits]\nmax_body_bytes = 65536\nmax_upload_bytes = 65536\n");
  REQUIRE_DAEMON(d);
  std::ofstream(d.assets() / "scene.json") << "{}";
  std::ofstream(d.dir() / "outside.gltf") << "{}";
  fs::create_symlink(d.dir() / "outside.gltf", d.assets() / "link.gltf");
  const std::string json_t = "application/json", png = "image/png";
  const std::vector<Malformed> table = {
      {"bad JSON", "POST", "/v1/render", json_t, png, R"({"width":64,)", 400, "request.syntax"},
      {"truncated JSON", "POST", "/v1/render", json_t, png, R"({"width":64,"height":3)", 400, "request.syntax"},
      {"not an object", "POST", "/v1/render", json_t, png, "[1,2,3]", 400, "request.type"},
      {"wrong type", "POST", "/v1/render", json_t, png, R"({"width":"64"})", 400, "request.type"},
      {"unknown field", "POST", "/v1/render", json_t, png, R"({"width":64,"colour":"red"})", 400,
       "request.unknown_field"},
      {"huge size", "POST", "/v1/render", json_t, png, R"({"width":1000000,"height":1000000})", 400, "request.limit"},
      {"over the limit", "POST", "/v1/render", json_t, png, R"({"width":8000,"height":100})", 400, "request.limit"},
      {"huge number", "POST", "/v1/render", json_t, png, R"({"width":1e999})", 400, "request.value"},
      {"deep nesting", "POST", "/v1/render", json_t, png, std::string(5000, '[') + std::string(5000, ']'), 400,
       "request.depth"},
      {"too many samples", "POST", "/v1/render", json_t, png, R"({"samples":100000})", 400, "request.limit"},
      {"path traversal", "POST", "/v1/render", json_t, png, R"({"scene":"../../../../etc/passwd.gltf"})", 403,
       "path.forbidden"},
      {"absolute path outside", "POST", "/v1/render", json_t, png, R"({"scene":"/etc/passwd.json"})", 403,
       "path.forbidden"},
      {"symlink escape", "POST", "/v1/render", json_t, png, R"({"scene":"link.gltf"})", 403, "path.forbidden"},
      {"missing asset", "POST", "/v1/render", json_t, png, R"({"scene":"nope.gltf"})", 404, "path.not_found"},
      {"LUT traversal", "POST", "/v1/render", json_t, png, R"({"grade":{"lut":"../x.cube"}})", 403, "path.forbidden"},
      {"dump name traversal", "POST", "/v1/render", json_t, png, R"({"dump":true,"name":"../x"})", 400,
       "request.value"},
      {"body over the limit", "POST", "/v1/render", json_t, png,
       R"({"scene":{"pad":")" + std::string(70000, 'x') + R"("}})", 413, "request.too_large"},
      {"upload over the limit", "POST", "/v1/encode", "image/x-exr", png, std::string(70000, 'x'), 413,
       "request.too_large"},
      {"wrong content type", "POST", "/v1/render", "image/png", png, "{}", 415, "request.media_type"},
      {"unacceptable Accept", "POST", "/v1/render", json_t, "text/html", "{}", 406, "request.not_acceptable"},
      {"wrong method", "GET", "/v1/render", "", png, "", 405, "request.method"},
      {"unknown endpoint", "GET", "/v2/render", "", png, "", 404, "request.not_found"},
      {"not an EXR", "POST", "/v1/encode", "image/x-exr", png, "GARBAGE", 422, "exr."},
      {"empty upload", "POST", "/v1/encode", "image/x-exr", png, "", 400, "request.value"},
      {"unknown query option", "POST", "/v1/encode?colour=red", "image/x-exr", png, "x", 400,
       "request.unknown_field"},
      {"bad scene JSON", "POST", "/v1/render", json_t, png, R"({"width":64,"height":36,"scene":{"lights":"many"}})",
       422, "scene."},
      {"unknown pattern", "POST", "/v1/pattern", json_t, png, R"({"pattern":"smpte"})", 400, "request.value"},
      {"pattern parameter typo", "POST", "/v1/pattern", json_t, png, R"({"pattern":"window","params":{"level":5}})",
       400, "request.unknown_field"},
      {"pattern parameter type", "POST", "/v1/pattern", json_t, png, R"({"pattern":"pq-ramp","params":{"steps":"9"}})",
       400, "request.type"},
      {"pattern too large", "POST", "/v1/pattern", json_t, png, R"({"pattern":"window","width":100000})", 400,
       "request.limit"},
      {"not an EDID", "POST", "/v1/render", json_t, png, R"({"width":8,"height":8,"display":{"edid":"scene.json"}})",
       422, "edid."},
      {"pattern bad JSON", "POST", "/v1/pattern", json_t, png, R"({"pattern":"window")", 400, "request.syntax"},
      {"selftest unknown mode", "POST", "/v1/selftest", json_t, png, R"({"mode":"hdr12"})", 400, "request.value"},
      {"selftest unknown field", "POST", "/v1/selftest", json_t, png, R"({"mode":"hdr10","peek":1})", 400,
       "request.unknown_field"},
      {"selftest GET", "GET", "/v1/selftest", "", png, "", 405, "request.method"},
  };
  auto c = d.client();
  for (const auto& m : table) {
    std::vector<std::pair<std::string, std::string>> headers = {{"Accept", m.accept}};
    if (!m.content_type.empty()) headers.emplace_back("Content-Type", m.content_type);
    auto r = c.request(m.method, m.path, m.body, headers);
    ASSERT_TRUE(r.ok()) << m.name << ": " << r.error().message;
    EXPECT_EQ(r->status, m.status) << m.name << ": " << r->body;
    EXPECT_EQ(error_code(*r).rfind(m.code, 0), 0u) << m.name << ": " << error_code(*r);
    if (m.status == 405) { EXPECT_NE(r->header("allow"), nullptr) << m.name; }
    auto ok = get(c, "/v1/status");
    ASSERT_EQ(ok.status, 200) << "after " << m.name << "\n" << d.log();
  }
  // Chunked upload (no Content-Length): refused before its body is read, 411 (issue 14: a
  // chunk line that never ends got libmicrohttpd's HTML 500).
  fs::path big = d.dir() / "big.json";
  std::ofstream(big) << R"({"scene":{"pad":")" << std::string(200000, 'y') << R"("}})";
  auto cr = run_command("curl -s -o /dev/null -w '%{http_code}' --unix-socket '" + d.socket().string() +
                        "' -H 'Transfer-Encoding: chunked' -H 'Content-Type: application/json' --data-binary @" +
                        big.string() + " http://localhost/v1/render");
  EXPECT_EQ(cr.out, "411");
  EXPECT_TRUE(d.alive());
}

TEST(DaemonE2E, MisbehavingConnectionsDoNotStopTheDaemon) {
  DaemonProcess d("connection_timeout_s = 1\n");
  REQUIRE_DAEMON(d);
  {  // Truncated body: Content-Length promises more than arrives, then the client stops writing.
    RawConnection raw(d.socket());
    ASSERT_TRUE(raw.connected());
    raw.send("POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: 100\r\n\r\n{\"wid");
    raw.shutdown_write();
    auto [got, closed] = raw.read_until_closed(std::chrono::seconds(30));
    EXPECT_TRUE(closed);
    EXPECT_EQ(got.find("200 OK"), std::string::npos);
  }
  {  // Slow client: half a request line, then nothing. Closed by the connection timeout.
    RawConnection raw(d.socket());
    raw.send("POST /v1/rend");
    auto [got, closed] = raw.read_until_closed(std::chrono::seconds(60));
    EXPECT_TRUE(closed) << "a stalled client is dropped";
  }
  {  // Slow body: headers, then part of the body, then nothing.
    RawConnection raw(d.socket());
    raw.send("POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Length: 50\r\n\r\n{\"width\":");
    auto [got, closed] = raw.read_until_closed(std::chrono::seconds(60));
    EXPECT_TRUE(closed);
  }
  {  // Not HTTP at all.
    RawConnection raw(d.socket());
    raw.send(std::string("\x00\x01\x02 GARBAGE \xff\r\n\r\n", 17));
    auto [got, closed] = raw.read_until_closed(std::chrono::seconds(30));
    EXPECT_TRUE(closed);
  }
  auto c = d.client();
  const double cancelled_before = metric(get(c, "/metrics").body, "hdrd_cancelled_total");
  {  // Disconnect mid-request: a large render, and the client hangs up at once.
    RawConnection raw(d.socket());
    const std::string body = render_body(1920, 1080, R"("exposure_comp_ev":1.25)");
    raw.send(fmt::format("POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\nContent-Length: "
                         "{}\r\n\r\n{}",
                         body.size(), body));
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    raw.close();
  }
  wait_idle(d);
  const double cancelled_after = metric(get(c, "/metrics").body, "hdrd_cancelled_total");
  EXPECT_EQ(cancelled_after, cancelled_before + 1) << "the job of the client that left was cancelled";
  auto r = post(c, "/v1/render", render_body(64, 36));
  EXPECT_EQ(r.status, 200) << "still serving";
  EXPECT_TRUE(d.alive());
}

// ---- security ------------------------------------------------------------------------------

TEST(DaemonE2E, SocketIsOwnerAndGroupOnly) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  struct stat st {};
  ASSERT_EQ(::stat(d.socket().c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0660u);
  EXPECT_NE(d.log().find("uid="), std::string::npos) << "peer credentials are logged";
}

TEST(DaemonE2E, TcpIsLoopbackAndNeedsTheBearerToken) {
  // A free loopback port.
  const int probe = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(probe, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  socklen_t len = sizeof a;
  ::getsockname(probe, reinterpret_cast<sockaddr*>(&a), &len);
  const int port = ntohs(a.sin_port);
  ::close(probe);

  TempDir tmp;
  std::ofstream(tmp / "token") << "0123456789abcdef-secret\n";
  DaemonProcess d(fmt::format("tcp_listen = \"127.0.0.1:{}\"\ntoken_file = \"{}\"\n", port, (tmp / "token").string()));
  // (the harness writes [server] last, so these two keys land in it)
  REQUIRE_DAEMON(d);
  daemon::ClientOptions o;
  o.tcp = fmt::format("127.0.0.1:{}", port);
  {
    daemon::Client c(o);
    auto r = c.request("GET", "/v1/status");
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_EQ(r->status, 401);
    EXPECT_NE(r->header("www-authenticate"), nullptr);
  }
  {
    o.token = "0123456789abcdef-wrong!";
    daemon::Client c(o);
    EXPECT_EQ(c.request("GET", "/v1/status")->status, 401);
  }
  {
    o.token = "0123456789abcdef-secret";
    daemon::Client c(o);
    EXPECT_EQ(c.request("GET", "/v1/status")->status, 200);
  }
  // Non-loopback addresses are refused unless explicitly allowed.
  DaemonProcess wide(fmt::format("tcp_listen = \"0.0.0.0:{}\"\ntoken = \"0123456789abcdef\"\n", port + 1), {}, {},
                     /*wait_ready=*/false);
  EXPECT_NE(wide.stop(0), 0);
  for (int i = 0; i < 500 && wide.alive(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_NE(wide.log().find("not a loopback address"), std::string::npos) << wide.log();
}

// ---- config reload, drain, socket activation ------------------------------------------------

TEST(DaemonE2E, SighupReloadsLimits) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  EXPECT_EQ(post(c, "/v1/render", render_body(96, 36)).status, 200);
  d.write_config("[limits]\nmax_width = 80\n");
  ::kill(d.pid(), SIGHUP);
  for (int i = 0; i < 500 && metric(get(c, "/metrics").body, "hdrd_config_reloads_total") < 1; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  auto r = post(c, "/v1/render", render_body(96, 36));
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(error_code(r), "request.limit");
  // A broken file on reload keeps the running configuration.
  d.write_config("[limits]\nmax_widht = 80\n");
  ::kill(d.pid(), SIGHUP);
  for (int i = 0; i < 500 && d.log().find("reload failed") == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_NE(d.log().find("reload failed"), std::string::npos);
  EXPECT_EQ(post(c, "/v1/render", render_body(96, 36)).status, 400) << "old limits still apply";
  EXPECT_EQ(post(c, "/v1/render", render_body(64, 36)).status, 200);
}

TEST(DaemonE2E, SigtermDrainsInFlightRequests) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  ClientResponse result;
  std::thread t([&] {
    auto c = d.client();
    result = post(c, "/v1/render", render_body(1280, 720));
  });
  auto c = d.client();
  for (int i = 0; i < 500; ++i) {
    auto s = json::parse(get(c, "/v1/status").body);
    if (s["queue"]["admitted"].get<int>() >= 1) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  c.close();
  EXPECT_EQ(d.stop(SIGTERM), 0);
  t.join();
  EXPECT_EQ(result.status, 200) << "the request in flight was finished, not dropped";
  EXPECT_TRUE(png_header(result.body).ok);
  EXPECT_FALSE(fs::exists(d.socket())) << "the socket file is removed";
}

TEST(DaemonE2E, SystemdSocketActivation) {
  TempDir tmp;
  const fs::path path = tmp / "activated.sock";
  const int fd = ::socket(AF_UNIX, SOCK_STREAM, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::snprintf(a.sun_path, sizeof a.sun_path, "%s", path.c_str());
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(::listen(fd, 16), 0);
  // sd_listen_fds(3): the socket on fd 3, LISTEN_FDS=1, LISTEN_PID = the daemon's pid.
  DaemonProcess d("", {}, [fd] {
    ::dup2(fd, 3);
    ::setenv("LISTEN_FDS", "1", 1);
    ::setenv("LISTEN_PID", std::to_string(::getpid()).c_str(), 1);
  }, /*wait_ready=*/false);
  ::close(fd);
  daemon::ClientOptions o;
  o.socket_path = path.string();
  bool up = false;
  for (int i = 0; i < 3000 && !up && d.alive(); ++i) {
    daemon::Client c(o);
    auto r = c.request("GET", "/v1/status");
    up = r.ok() && r->status == 200;
    if (up) { EXPECT_NE(r->body.find("systemd fd 3"), std::string::npos) << r->body; }
    else std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  ASSERT_TRUE(up) << d.log();
  EXPECT_FALSE(fs::exists(d.socket())) << "the configured socket is not bound when one is inherited";
}

// ---- grading, UI, display targets --------------------------------------------------------------

TEST(DaemonE2E, IdentityLutAndUiOverlay) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  // A 2-point identity lattice (Adobe Cube LUT spec 1.0: R fastest): exact under any interpolation.
  std::ofstream cube(d.assets() / "identity.cube");
  cube << "LUT_3D_SIZE 2\n";
  for (int b = 0; b < 2; ++b)
    for (int g = 0; g < 2; ++g)
      for (int r = 0; r < 2; ++r) cube << r << " " << g << " " << b << "\n";
  cube.close();
  auto c = d.client();
  const std::string raw_t = "application/octet-stream";
  auto plain = post(c, "/v1/render", render_body(64, 36, R"("display":{"mode":"sdr","bits":10})"), raw_t);
  auto graded = post(c, "/v1/render", render_body(64, 36, R"("display":{"mode":"sdr","bits":10},"grade":{"lut":"identity.cube"})"),
                     raw_t);
  ASSERT_EQ(plain.status, 200) << plain.body;
  ASSERT_EQ(graded.status, 200) << graded.body;
  ASSERT_EQ(plain.body.size(), graded.body.size());
  int worst = 0;  // XBGR2101010: three 10-bit codes per 32-bit little-endian word
  for (std::size_t i = 0; i + 4 <= plain.body.size(); i += 4) {
    std::uint32_t p, q;
    std::memcpy(&p, plain.body.data() + i, 4);
    std::memcpy(&q, graded.body.data() + i, 4);
    for (int s = 0; s < 30; s += 10) worst = std::max(worst, std::abs(int((p >> s) & 1023) - int((q >> s) & 1023)));
  }
  EXPECT_LE(worst, 1) << "an identity LUT changes nothing beyond rounding";

  // A white 8x8 UI (uploaded as base64) at (0,0) changes those pixels and only those.
  auto ui_png = post(c, "/v1/render", render_body(8, 8, R"("display":{"mode":"sdr"},"exposure_comp_ev":12)"));
  ASSERT_EQ(ui_png.status, 200);
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string b64;
  const std::string& in = ui_png.body;
  for (std::size_t i = 0; i < in.size(); i += 3) {
    unsigned v = (unsigned char)in[i] << 16;
    if (i + 1 < in.size()) v |= (unsigned char)in[i + 1] << 8;
    if (i + 2 < in.size()) v |= (unsigned char)in[i + 2];
    b64 += k[v >> 18];
    b64 += k[(v >> 12) & 63];
    b64 += i + 1 < in.size() ? k[(v >> 6) & 63] : '=';
    b64 += i + 2 < in.size() ? k[v & 63] : '=';
  }
  auto with_ui = post(c, "/v1/render",
                      render_body(64, 36, R"("display":{"mode":"sdr","bits":10},"ui":{"png_base64":")" + b64 +
                                              R"(","x":0,"y":0})"),
                      raw_t);
  ASSERT_EQ(with_ui.status, 200) << with_ui.body;
  const std::size_t stride = std::stoul(*plain.header("x-hdrd-stride"));
  int changed_inside = 0, changed_outside = 0;
  for (int y = 0; y < 36; ++y)
    for (int x = 0; x < 64; ++x) {
      const bool differs = std::memcmp(plain.body.data() + y * stride + x * 4, with_ui.body.data() + y * stride + x * 4, 4) != 0;
      (x < 8 && y < 8 ? changed_inside : changed_outside) += differs ? 1 : 0;
    }
  EXPECT_GT(changed_inside, 32);
  EXPECT_EQ(changed_outside, 0);
}

TEST(DaemonE2E, DisplayAutoAndEdidTargets) {
  HDRD_REQUIRE_FIXTURE(edid, "fixtures/edid/DELA0EA_29633DC619A6.bin");
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  fs::copy_file(edid, d.assets() / "monitor.bin");
  auto c = d.client();
  auto r = post(c, "/v1/render", render_body(64, 36, R"("display":{"edid":"monitor.bin"})"));
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(r.header("x-hdrd-target-source")->rfind("edid", 0), 0u) << *r.header("x-hdrd-target-source");
  auto forced = post(c, "/v1/render", render_body(64, 36, R"("display":{"edid":"monitor.bin","peak_nits":321})"));
  ASSERT_EQ(forced.status, 200);
  EXPECT_EQ(*forced.header("x-hdrd-peak-nits"), "321") << "the request's own values win over the EDID";
  // No display is attached here: auto keeps the defaults and says so.
  auto a = post(c, "/v1/render", render_body(64, 36, R"("display":"auto")"));
  EXPECT_EQ(a.status, 200) << a.body;
}

// ---- patterns and the self-test (issue 7) -------------------------------------------------

std::uint16_t png_sample(const io::PngInfo& png, int x, int y, int channel) {
  return png.samples[(std::size_t(y) * png.width + x) * png.channels + channel];
}

std::uint32_t raw_code(const ClientResponse& r, int x, int y, int channel) {
  const std::size_t stride = std::stoul(*r.header("x-hdrd-stride"));
  std::uint32_t word = 0;
  std::memcpy(&word, r.body.data() + y * stride + x * 4, 4);
  return (word >> (10 * channel)) & 0x3ff;  // XBGR2101010: R in the low bits
}

TEST(DaemonE2E, PatternBt2111BarsThroughCurl) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  const fs::path out = d.dir() / "bars.png";
  auto r = run_command("curl -sS --fail --unix-socket '" + d.socket().string() + "' -H 'Accept: image/png' -d "
                       "'{\"pattern\":\"bt2111\",\"width\":480,\"height\":270,\"display\":{\"mode\":\"hdr10\"}}' "
                       "http://localhost/v1/pattern -o '" + out.string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.err << "\n" << d.log();
  const std::string bytes = read_file(out);
  auto png = io::read_png_info_memory({reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()});
  ASSERT_TRUE(png.ok()) << png.error().message;
  ASSERT_EQ(png->width, 480);
  ASSERT_EQ(png->bit_depth, 16);
  // H.273: BT.2020 primaries, PQ, RGB, narrow range (BT.2111-2 defines the bars in narrow range).
  ASSERT_TRUE(png->cicp.has_value());
  EXPECT_EQ(*png->cicp, (std::array<std::uint8_t, 4>{9, 16, 0, 0}));
  // BT.2111-2 table 2 (PQ, 10-bit narrow): 100 % white = 940, reference (58 %) white = 572;
  // the 16-bit PNG sample of a narrow code D is D x 2^6 (BT.2100 table 9). The 1920-wide
  // layout at a quarter: the white bars span x 60..111; row 1 is y < 22.5, row 2 below it.
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(png_sample(*png, 85, 10, c), 940u << 6) << "100% white, channel " << c;
    EXPECT_EQ(png_sample(*png, 85, 80, c), 572u << 6) << "ref white, channel " << c;
  }
  EXPECT_EQ(png_sample(*png, 20, 10, 0), 414u << 6) << "40 % grey at the left edge";
}

TEST(DaemonE2E, PatternWindowLevelInEveryForm) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  const std::string body =
      R"({"pattern":"window","width":96,"height":54,"params":{"level_nits":1000,"area_percent":10},)"
      R"("display":{"mode":"hdr10","peak_nits":1000}})";
  // ST 2084: 1000 cd/m2 is PQ 0.7518, code 769 of 1023 in full range; the background is 0.
  const auto level_code = std::uint32_t(std::lround(transfer::pq_inverse_eotf(1000.0) * 1023));
  auto raw = post(c, "/v1/pattern", body, "application/octet-stream");
  ASSERT_EQ(raw.status, 200) << raw.body;
  EXPECT_EQ(*raw.header("x-hdrd-pattern"), "window");
  EXPECT_EQ(raw.header("x-hdrd-tone-curve"), nullptr) << "a pattern's codes are exact: no tone curve";
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_EQ(raw_code(raw, 48, 27, ch), level_code) << "window centre";
    EXPECT_EQ(raw_code(raw, 2, 2, ch), 0u) << "background";
  }
  auto png_reply = post(c, "/v1/pattern", body, "image/png");
  ASSERT_EQ(png_reply.status, 200);
  auto png = io::read_png_info_memory(
      {reinterpret_cast<const std::uint8_t*>(png_reply.body.data()), png_reply.body.size()});
  ASSERT_TRUE(png.ok()) << png.error().message;
  const double nits = transfer::pq_eotf(png_sample(*png, 48, 27, 1) / 65535.0);
  EXPECT_NEAR(nits, 1000.0, 1000.0 - transfer::pq_eotf((level_code - 1) / 1023.0)) << "within one code";
  auto exr = post(c, "/v1/pattern", body, "image/x-exr");
  ASSERT_EQ(exr.status, 200) << exr.body;
  auto decoded = io::read_exr_memory({reinterpret_cast<const std::uint8_t*>(exr.body.data()), exr.body.size()});
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  const double exr_nits = decoded->image.px(48, 27)[1] * *decoded->white_luminance;
  EXPECT_NEAR(exr_nits, 1000.0, 5.0) << "EXR value x whiteLuminance = cd/m2 (half float)";
  // The same window for scRGB (no PNG form) comes back as EXR by default.
  auto scrgb = post(c, "/v1/pattern", R"({"pattern":"window","width":96,"height":54,"display":{"mode":"scrgb"}})",
                    "*/*");
  ASSERT_EQ(scrgb.status, 200) << scrgb.body;
  EXPECT_EQ(*scrgb.header("content-type"), "image/x-exr");
}

TEST(DaemonE2E, PatternDumpAndModeErrors) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  auto dump = post(c, "/v1/pattern",
                   R"({"pattern":"clipping","width":192,"height":108,"params":{"level_nits":600},"dump":true,)"
                   R"("name":"clip","display":{"mode":"hdr10","peak_nits":1000}})",
                   "application/json");
  ASSERT_EQ(dump.status, 200) << dump.body;
  const auto side = json::parse(dump.body);
  EXPECT_EQ(side["settings"]["pattern"]["name"], "clipping");
  EXPECT_EQ(side["settings"]["pattern"]["level_nits"], 600);
  for (const char* f : {"png", "exr", "raw"}) EXPECT_TRUE(fs::exists(d.dumps() / (std::string("clip.") + f))) << f;
  auto bad = post(c, "/v1/pattern", R"({"pattern":"bt2111","display":{"mode":"sdr"}})");
  EXPECT_EQ(bad.status, 400);
  EXPECT_EQ(json::parse(bad.body)["error"]["field"], "display.mode");
  auto tone = post(c, "/v1/pattern", R"({"pattern":"window","tone":{"curve":"bt2390"}})");
  EXPECT_EQ(tone.status, 400);
  EXPECT_EQ(json::parse(tone.body)["error"]["field"], "tone.curve");
}

TEST(DaemonE2E, SelftestHdr10At1000NitsPasses) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  auto r = post(c, "/v1/selftest", R"({"mode":"hdr10","peak_nits":1000})", "application/json");
  ASSERT_EQ(r.status, 200) << r.body;
  EXPECT_EQ(*r.header("x-hdrd-selftest"), "passed");
  const auto report = json::parse(r.body);
  EXPECT_EQ(report["mode"], "hdr10");
  EXPECT_EQ(report["peak_nits"], 1000);
  EXPECT_TRUE(report["passed"].get<bool>()) << report.dump(1);
  std::set<std::string> names;
  for (const auto& check : report["checks"]) {
    names.insert(check["name"]);
    EXPECT_FALSE(check["source"].get<std::string>().empty()) << "each check names its source";
  }
  EXPECT_TRUE(names.count("paper-white/clip"));
  const bool rendered = json::parse(get(c, "/v1/status").body)["renderer"]["available"].get<bool>();
  if (rendered) { EXPECT_TRUE(names.count("peak/scene-material-grid")) << "the render worker rendered the scenes"; }
  // No body: hdr10 at its default peak. render=false: the scene checks are skipped, not failed.
  auto plain = c.request("POST", "/v1/selftest", "", {});
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->status, 200) << plain->body;
  auto quick = post(c, "/v1/selftest", R"({"mode":"hlg","render":false})", "application/json");
  ASSERT_EQ(quick.status, 200) << quick.body;
  bool skipped_render = false;
  const auto quick_report = json::parse(quick.body);
  for (const auto& check : quick_report["checks"])
    if (check["name"] == "render") skipped_render = check["skipped"].get<bool>();
  EXPECT_TRUE(skipped_render) << quick.body;
}

// ---- clients -----------------------------------------------------------------------------------

TEST(DaemonE2E, HdrctlAndPythonClient) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  const std::string hdrctl = (binary_dir() / "tools/hdrctl/hdrctl").string() + " --socket '" + d.socket().string() + "'";
  const fs::path out = d.dir() / "ctl.png";
  auto r = run_command(hdrctl + " render --width 256 --height 144 --mode hdr10 --peak 1000 -o " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(png_header(read_file(out)).width, 256u);
  r = run_command(hdrctl + " --json status");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(json::parse(r.out)["service"], "hdrd");
  r = run_command(hdrctl + " render --width 99999 -o /dev/null");
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("request.limit"), std::string::npos) << r.err;
  r = run_command(hdrctl + " metrics");
  EXPECT_EQ(r.exit_code, 0);
  EXPECT_NE(r.out.find("hdrd_requests_total"), std::string::npos);
  r = run_command(hdrctl + " metrics --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  bool labelled = false;
  const auto metrics_json = json::parse(r.out);
  for (const auto& sample : metrics_json["samples"])
    if (sample["name"] == "hdrd_requests_total" && sample["labels"].contains("endpoint")) labelled = true;
  EXPECT_TRUE(labelled) << r.out.substr(0, 400);
  EXPECT_EQ(metrics_json["types"]["hdrd_requests_total"], "counter");
  r = run_command(hdrctl + " status --json");
  ASSERT_EQ(r.exit_code, 0) << "global options after the subcommand: " << r.err;
  EXPECT_EQ(json::parse(r.out)["service"], "hdrd");

  const fs::path bars = d.dir() / "bars.png";
  r = run_command(hdrctl + " pattern bt2111 --mode hlg --width 480 --height 270 -o " + bars.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("bt2111 hlg 480x270"), std::string::npos) << r.err;
  EXPECT_EQ(png_header(read_file(bars)).cicp, std::string("\x09\x12\x00\x00", 4)) << "HLG, narrow range";
  r = run_command(hdrctl + " pattern --list --json");
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(json::parse(r.out).size(), 7u) << "issue 7's six patterns and issue 15's sdr-shadows";
  r = run_command(hdrctl + " pattern bt2111 --mode sdr -o " + (d.dir() / "no.png").string());
  EXPECT_EQ(r.exit_code, 1);
  EXPECT_NE(r.err.find("display.mode"), std::string::npos) << r.err;
  r = run_command(hdrctl + " selftest --mode hdr10 --peak 1000");
  EXPECT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_NE(r.out.find("0 failed"), std::string::npos) << r.out;
  r = run_command(hdrctl + " selftest --mode sdr --no-render --json");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_TRUE(json::parse(r.out)["passed"].get<bool>());

  if (run_command("python3 --version").exit_code != 0) GTEST_SKIP() << "python3 missing";
  const fs::path example = source_dir() / "clients/python/example.py";
  r = run_command("python3 '" + example.string() + "' --socket '" + d.socket().string() + "' --out '" +
                  d.dir().string() + "'");
  ASSERT_EQ(r.exit_code, 0) << r.out << r.err;
  EXPECT_EQ(png_header(read_file(d.dir() / "example-hdr10.png")).width, 256u);
  EXPECT_EQ(png_header(read_file(d.dir() / "example-window.png")).width, 192u);
  EXPECT_NE(r.out.find("passed=True"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace hdrd::testing
