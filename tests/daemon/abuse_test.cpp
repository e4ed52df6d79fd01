// The daemon under abuse (issue 14), end to end against the real `hdrd serve`: each
// item the issue found, as an attacker sends it over the Unix socket with raw requests.
// The oracle is the HTTP contract itself: no crash, a 4xx with the JSON error for the
// client's faults, new clients served within a second while others misbehave.
#include <gtest/gtest.h>

#include <sys/mount.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <memory>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "job/settings.hpp"
#include "encode/io/io.hpp"
#include "tests/daemon/daemon_harness.hpp"

namespace hdrd::testing {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using daemon::ClientResponse;
using Clock = std::chrono::steady_clock;

#define REQUIRE_DAEMON(d) \
  ASSERT_TRUE((d).ready()) << "hdrd serve did not come up; its log:\n" << (d).log()

std::string tiny_exr() {
  Image img(8, 4);
  for (float& v : img.rgba) v = 0.25f;
  auto bytes = io::encode_exr(img, {});
  EXPECT_TRUE(bytes.ok());
  return bytes.ok() ? std::string(bytes->begin(), bytes->end()) : std::string();
}

std::string error_code(const std::string& body) {
  auto j = json::parse(body, nullptr, false);
  return j.is_object() && j.contains("error") ? j["error"].value("code", "") : "(not a JSON error: " + body.substr(0, 80) + ")";
}
std::string error_code(const ClientResponse& r) { return error_code(r.body); }

ClientResponse request(daemon::Client& c, const std::string& method, const std::string& target,
                       const std::string& body = {}, std::vector<std::pair<std::string, std::string>> headers = {}) {
  auto r = c.request(method, target, body, headers);
  EXPECT_TRUE(r.ok()) << target << ": " << (r.ok() ? "" : r.error().message);
  return r.ok() ? *r : ClientResponse{};
}

ClientResponse encode_multipart(daemon::Client& c, const std::string& options_json, const std::string& exr) {
  std::string type;
  const std::string body =
      daemon::multipart_body({{"image", "a.exr", "image/x-exr", exr}, {"request", "", "application/json", options_json}},
                             &type);
  return request(c, "POST", "/v1/encode", body, {{"Content-Type", type}, {"Accept", "application/octet-stream"}});
}

// A raw HTTP exchange: what came back, split into status and body.
struct RawReply {
  int status = 0;
  std::string body, all;
};
RawReply parse_reply(const std::string& text) {
  RawReply r;
  r.all = text;
  if (text.rfind("HTTP/1.1 ", 0) == 0) r.status = std::atoi(text.c_str() + 9);
  if (const auto p = text.find("\r\n\r\n"); p != std::string::npos) r.body = text.substr(p + 4);
  return r;
}

long rss_peak_kib(pid_t pid) {
  std::ifstream f(fmt::format("/proc/{}/status", pid));
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

// A connection that may be opened in the thousands: plain fd, no reads.
int connect_unix(const fs::path& socket) {
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::snprintf(a.sun_path, sizeof a.sun_path, "%s", socket.c_str());
  if (::connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// The worst time a new client waited for GET /v1/status, over `probes` fresh connections.
double worst_probe_s(const DaemonProcess& d, int probes, std::chrono::milliseconds gap, int* failures) {
  double worst = 0;
  for (int i = 0; i < probes; ++i) {
    daemon::Client c(d.options(5));
    const auto t0 = Clock::now();
    auto r = c.request("GET", "/v1/status");
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    worst = std::max(worst, s);
    if (!r || r->status != 200) ++*failures;
    std::this_thread::sleep_for(gap);
  }
  return worst;
}

void raise_fd_limit() {
  rlimit rl{};
  if (::getrlimit(RLIMIT_NOFILE, &rl) == 0 && rl.rlim_cur < rl.rlim_max) {
    rl.rlim_cur = rl.rlim_max;
    ::setrlimit(RLIMIT_NOFILE, &rl);
  }
}

// ---- 1. depth before parsing ---------------------------------------------------------------

TEST(DaemonAbuse, DeepJsonInAMultipartPartIsRefusedWithoutACrash) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  const std::string deep = std::string(100000, '[') + std::string(100000, ']');
  auto r = encode_multipart(c, deep, tiny_exr());
  EXPECT_EQ(r.status, 400);
  EXPECT_EQ(error_code(r), "request.depth");
  std::string objects;
  for (int i = 0; i < 100000; ++i) objects += "{\"a\":";
  r = encode_multipart(c, objects, tiny_exr());
  EXPECT_EQ(r.status, 400) << "unterminated, as deep";
  EXPECT_EQ(error_code(r), "request.depth");
  EXPECT_TRUE(d.alive());
  EXPECT_EQ(encode_multipart(c, R"({"display":{"mode":"sdr"}})", tiny_exr()).status, 200) << "still serving";
}

// glTF "extras" 20 000 arrays deep: tinygltf converts them recursively. Refused first, by
// `hdrd serve` from the asset root and by `hdrd render`.
TEST(DaemonAbuse, DeepGltfIsRefusedByServeAndByRender) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  const std::string extras = std::string(20000, '[') + std::string(20000, ']');
  std::ofstream(d.assets() / "deep.gltf") << R"({"asset":{"version":"2.0"},"extras":)" << extras << "}";
  auto c = d.client();
  auto r = request(c, "POST", "/v1/render", R"({"scene":"deep.gltf","width":32,"height":18})",
                   {{"Content-Type", "application/json"}});
  EXPECT_TRUE(d.alive());
  if (r.status == 503) GTEST_SKIP() << "no renderer here: " << r.body;
  EXPECT_EQ(r.status, 422) << r.body;
  EXPECT_EQ(error_code(r), "gltf.json_depth");
  const auto cli = run_command(fmt::format("{} render --scene {} --width 32 --height 18 -o {}", hdrd_binary().string(),
                                           (d.assets() / "deep.gltf").string(), (d.dir() / "out").string()));
  EXPECT_NE(cli.exit_code, 0);
  EXPECT_LT(cli.exit_code, 128) << "ended by a signal: " << cli.err;
  EXPECT_NE(cli.err.find("nested deeper"), std::string::npos) << cli.err;
}

// ---- 3. 4xx for the client's faults --------------------------------------------------------

TEST(DaemonAbuse, InvalidUtf8OrNulInAnyQueryParameterIs400) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  const std::string exr = tiny_exr();
  for (const auto& p : job::settings()) {  // every query parameter of an encode request
    if (p.query.empty() || !job::applies(p.sources, job::Source::encode)) continue;
    for (const char* value : {"%ff", "%c0%af", "hdr10%00", "%ed%a0%80"}) {
      auto r = request(c, "POST", fmt::format("/v1/encode?{}={}", p.query, value), exr,
                       {{"Content-Type", "image/x-exr"}, {"Accept", "application/octet-stream"}});
      EXPECT_EQ(r.status, 400) << p.query << "=" << value << ": " << r.body;
      EXPECT_EQ(error_code(r), "request.query") << p.query << "=" << value;
    }
  }
  auto r = request(c, "POST", "/v1/encode?%ff=1", exr, {{"Content-Type", "image/x-exr"}});
  EXPECT_EQ(r.status, 400) << "a name";
  r = request(c, "GET", "/v1/status?x=%ff");
  EXPECT_EQ(r.status, 400) << "every endpoint";
  r = request(c, "POST", "/v1/encode?mode=sdr&peak_nits=120", exr,
              {{"Content-Type", "image/x-exr"}, {"Accept", "application/octet-stream"}});
  EXPECT_EQ(r.status, 200) << r.body;
}

// Symbolic and hard links inside the asset root, and a file that is not an EDID: the
// non-EDID is 422 (was 500 edid.too_short); links are refused by the file model. A link out
// of the root stays forbidden.
TEST(DaemonAbuse, LinksInTheAssetRootToNonEdidFilesAre422) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  std::ofstream(d.assets() / "notes.txt") << "not an EDID\n";
  std::ofstream(d.assets() / "big.bin") << std::string(256, 'x');
  std::ofstream(d.dir() / "outside.txt") << "secret\n";
  fs::create_symlink(d.assets() / "notes.txt", d.assets() / "sym.bin");
  fs::create_hard_link(d.assets() / "notes.txt", d.assets() / "hard.bin");
  fs::create_hard_link(d.dir() / "outside.txt", d.assets() / "hard-out.bin");
  fs::create_symlink(d.dir() / "outside.txt", d.assets() / "escape.bin");
  fs::create_directory(d.assets() / "dir");
  fs::create_symlink(d.assets() / "dir", d.assets() / "dirlink.bin");
  auto c = d.client();
  const std::string exr = tiny_exr();
  // The file model (issue 28, docs/api.md "Security"): a file that is not an EDID is 422
  // edid.*; a file with more than one hard link is refused (403 path.hard_link: notes.txt
  // too, once hard.bin links it). A symbolic link inside the root is resolved when the
  // request arrives (sym.bin is notes.txt, so the same refusal), never when it is read.
  auto r0 = encode_multipart(c, R"({"display":{"edid":"big.bin"}})", exr);
  EXPECT_EQ(r0.status, 422) << r0.body;
  EXPECT_EQ(error_code(r0).rfind("edid.", 0), 0u) << r0.body;
  for (const auto& [name, code] : std::vector<std::pair<std::string, std::string>>{
           {"sym.bin", "path.hard_link"}, {"hard.bin", "path.hard_link"}, {"hard-out.bin", "path.hard_link"},
           {"notes.txt", "path.hard_link"}}) {
    auto r = encode_multipart(c, fmt::format(R"({{"display":{{"edid":"{}"}}}})", name), exr);
    EXPECT_EQ(r.status, 403) << name << ": " << r.body;
    EXPECT_EQ(error_code(r), code) << name << ": " << r.body;
  }
  auto r = encode_multipart(c, R"({"display":{"edid":"escape.bin"}})", exr);
  EXPECT_EQ(r.status, 403) << r.body;
  r = encode_multipart(c, R"({"display":{"edid":"dirlink.bin"}})", exr);
  EXPECT_EQ(r.status, 404) << r.body;
  EXPECT_TRUE(d.alive());
}

// Issue 28.9: every malformed Radiance .hdr environment map answered 500 (hdr.*), where the
// EXR equivalents answered 422: the request named a file that cannot be used, 422 for both.
TEST(DaemonAbuse, MalformedEnvironmentMapsAre422ForRadianceAsForExr) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto radiance = [](const std::string& resolution, const std::string& data) {
    return "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + resolution + data;
  };
  const std::pair<const char*, std::string> maps[] = {
      {"huge.hdr", radiance("-Y 100000 +X 200000\n", "")},                                        // declared size
      {"rle-truncated.hdr", radiance("-Y 8 +X 16\n", std::string("\x02\x02\x00\x10\x83", 5))},  // RLE ends early
      {"rle-overrun.hdr", radiance("-Y 8 +X 16\n", std::string("\x02\x02\x00\x10\xff\x01", 6))},  // run of 127 in 16
      {"no-resolution.hdr", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n"},
      {"truncated.exr", tiny_exr().substr(0, 40)},
  };
  auto c = d.client();
  for (const auto& [name, bytes] : maps) {
    std::ofstream(d.assets() / name, std::ios::binary) << bytes;
    auto r = request(c, "POST", "/v1/render",
                     fmt::format(R"({{"width":16,"height":8,"environment":{{"file":"{}"}}}})", name),
                     {{"Content-Type", "application/json"}});
    EXPECT_EQ(r.status, 422) << name << ": " << r.body;
    const std::string family = fs::path(name).extension() == ".hdr" ? "hdr." : "exr.";
    EXPECT_EQ(error_code(r).rfind(family, 0), 0u) << name << ": " << r.body;
  }
  EXPECT_TRUE(d.alive());
}

// A chunk line that never ends filled libmicrohttpd's buffer and got its HTML 500. Bodies
// must declare their length: a chunked one is answered 411 with the JSON error, before
// MHD reads a byte of it.
TEST(DaemonAbuse, ChunkExtensionBombIsA411WithTheJsonError) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  for (const std::string& tail : {"1;" + std::string(200000, 'a'), std::string("4\r\nabcd\r\n0\r\n\r\n")}) {
    RawConnection raw(d.socket());
    ASSERT_TRUE(raw.connected());
    raw.send("POST /v1/encode HTTP/1.1\r\nHost: x\r\nContent-Type: image/x-exr\r\nTransfer-Encoding: chunked\r\n\r\n" +
             tail);  // the daemon may stop reading: a failed send is fine
    auto [text, closed] = raw.read_until_closed(std::chrono::seconds(10));
    const RawReply reply = parse_reply(text);
    EXPECT_EQ(reply.status, 411) << text.substr(0, 200);
    EXPECT_EQ(error_code(reply.body), "request.length_required");
    EXPECT_TRUE(closed);
  }
  EXPECT_TRUE(d.alive());
}

// ---- 5. config values that parse but break everything --------------------------------------

TEST(DaemonAbuse, AnOverflowingDurationOnReloadIsRefusedAndRequestsGoOn) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  const std::string exr = tiny_exr();
  auto encode = [&] {
    return request(c, "POST", "/v1/encode?mode=sdr", exr, {{"Content-Type", "image/x-exr"}, {"Accept", "image/png"}});
  };
  EXPECT_EQ(encode().status, 200);
  d.write_config("[limits]\nmax_request_seconds = 1e300\n");
  ::kill(d.pid(), SIGHUP);
  for (int i = 0; i < 500 && d.log().find("reload failed") == std::string::npos; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_NE(d.log().find("limits.max_request_seconds"), std::string::npos) << d.log();
  auto r = encode();
  EXPECT_EQ(r.status, 200) << "not 504 'timed out while queued': " << r.body;
}

// A dump directory that cannot be written is reported at start, naming the key.
TEST(DaemonAbuse, AnUnwritableDumpDirectoryStopsTheStart) {
  DaemonProcess d("", {"--dump-dir", "/proc/hdrd-not-a-place/dumps"}, {}, /*wait_ready=*/false);
  for (int i = 0; i < 1000 && d.alive(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  EXPECT_FALSE(d.alive());
  EXPECT_NE(d.stop(), 0);
  EXPECT_NE(d.log().find("paths.dump_dir"), std::string::npos) << d.log();
}

// ---- 2 and 6. slow clients -----------------------------------------------------------------

// 64 connections trickling a request one byte at a time, then 1000 connections opened at
// once and left idle: a new client is answered within a second throughout.
TEST(DaemonAbuse, SlowAndIdleConnectionsDoNotStopNewClients) {
  raise_fd_limit();
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  std::atomic<bool> stop{false};
  std::vector<std::unique_ptr<RawConnection>> slow;
  for (int i = 0; i < 64; ++i) slow.push_back(std::make_unique<RawConnection>(d.socket()));
  std::thread trickle([&] {
    const std::string req = "GET /v1/status HTTP/1.1\r\nHost: x\r\nX-Pad: " + std::string(400, 'p') + "\r\n\r\n";
    for (std::size_t i = 0; i < req.size() && !stop; ++i) {
      for (auto& s : slow) s->send(std::string(1, req[i]));
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  int failures = 0;
  const double worst_slow = worst_probe_s(d, 10, std::chrono::milliseconds(100), &failures);
  EXPECT_EQ(failures, 0);
  EXPECT_LT(worst_slow, 1.0) << "probe latency with 64 trickling connections";

  std::vector<int> flood;
  for (int i = 0; i < 1000; ++i)
    if (const int fd = connect_unix(d.socket()); fd >= 0) flood.push_back(fd);
  EXPECT_GT(flood.size(), 900u);
  failures = 0;
  const double worst_flood = worst_probe_s(d, 10, std::chrono::milliseconds(50), &failures);
  EXPECT_EQ(failures, 0);
  EXPECT_LT(worst_flood, 1.0) << "probe latency with 1000 idle connections";
  stop = true;
  trickle.join();
  for (int fd : flood) ::close(fd);
  EXPECT_TRUE(d.alive());
}

// Every connection holds a request in progress: a new one is refused with 503
// server.busy. A client that sends its whole request (4 MiB, more than the socket buffers
// hold) before it reads gets that answer, not a broken pipe: the body is read and dropped.
TEST(DaemonAbuse, ARefusalForRoomIsA503EvenForAClientStillSendingItsBody) {
  DaemonProcess d("max_connections = 2\nmax_connections_per_peer = 2\n");
  REQUIRE_DAEMON(d);
  RawConnection a(d.socket()), b(d.socket());
  // "100 Continue" says the daemon has taken the header: the connection is in its body.
  const std::string slow_head = "POST /v1/encode HTTP/1.1\r\nHost: x\r\nContent-Type: image/x-exr\r\n"
                                "Content-Length: 1000000\r\nExpect: 100-continue\r\n\r\n";
  for (RawConnection* s : {&a, &b}) {
    ASSERT_TRUE(s->send(slow_head));
    ASSERT_NE(s->read_until("100 Continue\r\n\r\n", std::chrono::seconds(10)).find("100 Continue"), std::string::npos);
    ASSERT_TRUE(s->send("v/1"));
  }
  RawConnection c(d.socket());
  const std::string body = R"({"width":64,"pad":")" + std::string(4 << 20, 'p') + "\"}";
  const bool sent = c.send(fmt::format("POST /v1/render HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
                                       "Content-Length: {}\r\n\r\n", body.size()) + body);
  EXPECT_TRUE(sent) << "the daemon closed the connection while the body was being sent";
  auto [text, closed] = c.read_until_closed(std::chrono::seconds(10));
  const auto reply = parse_reply(text);
  EXPECT_EQ(reply.status, 503) << text.substr(0, 300);
  EXPECT_EQ(error_code(reply.body), "server.busy");
  EXPECT_NE(text.find("Retry-After: 1"), std::string::npos);
  EXPECT_TRUE(d.alive());
}

TEST(DaemonAbuse, TricklingHeadersAndSlowBodiesAreClosedWithA408) {
  DaemonProcess d("header_timeout_s = 1\nbody_grace_s = 0.5\nmin_body_bytes_per_s = 100000\n");
  REQUIRE_DAEMON(d);
  RawConnection header(d.socket()), body(d.socket()), idle(d.socket());
  const auto t0 = Clock::now();
  header.send("GET /v1/status HTTP/1.1\r\nHost: x\r\n");
  body.send("POST /v1/encode HTTP/1.1\r\nHost: x\r\nContent-Type: image/x-exr\r\nContent-Length: 1000000\r\n\r\nv/1");
  std::thread drip([&] {
    for (int i = 0; i < 30; ++i) {
      header.send("X");
      body.send("x");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  });
  auto [h_text, h_closed] = header.read_until_closed(std::chrono::seconds(5));
  const double h_s = std::chrono::duration<double>(Clock::now() - t0).count();
  auto [b_text, b_closed] = body.read_until_closed(std::chrono::seconds(5));
  auto [i_text, i_closed] = idle.read_until_closed(std::chrono::seconds(5));
  drip.join();
  EXPECT_TRUE(h_closed);
  EXPECT_LT(h_s, 2.5) << "the header deadline is 1 s";
  EXPECT_EQ(parse_reply(h_text).status, 408) << h_text;
  EXPECT_EQ(error_code(parse_reply(h_text).body), "request.header_timeout");
  EXPECT_TRUE(b_closed);
  EXPECT_EQ(parse_reply(b_text).status, 408) << b_text;
  EXPECT_EQ(error_code(parse_reply(b_text).body), "request.body_timeout");
  EXPECT_TRUE(i_closed);
  EXPECT_EQ(i_text, "") << "an idle connection is closed without a reply";
  auto c = d.client();
  EXPECT_EQ(request(c, "GET", "/v1/status").status, 200);
}

// ---- 4. memory ------------------------------------------------------------------------------

// A PNG of a few bytes that declares 16384 x 8192 pixels: refused from its header, before
// anything is decoded (it drove the daemon to 4.3 GB and was answered 200).
TEST(DaemonAbuse, AUiPngDeclaringAHugeSizeIsRefusedBeforeDecoding) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  // Signature, IHDR 16384 x 8192 RGBA8 (CRC not checked before the size), IDAT, IEND.
  std::string png("\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR\0\0\x40\0\0\0\x20\0\x08\x06\0\0\0\0\0\0\0", 33);
  png += std::string("\0\0\0\x09IDAT\x78\x9c\x63\x00\x00\x00\x01\x00\x01\0\0\0\0", 21);
  png += std::string("\0\0\0\0IEND\xae\x42\x60\x82", 12);
  static const char* kB64 = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string b64;
  for (std::size_t i = 0; i < png.size(); i += 3) {
    std::uint32_t v = std::uint32_t(std::uint8_t(png[i])) << 16;
    if (i + 1 < png.size()) v |= std::uint32_t(std::uint8_t(png[i + 1])) << 8;
    if (i + 2 < png.size()) v |= std::uint8_t(png[i + 2]);
    b64 += kB64[(v >> 18) & 63];
    b64 += kB64[(v >> 12) & 63];
    b64 += i + 1 < png.size() ? kB64[(v >> 6) & 63] : '=';
    b64 += i + 2 < png.size() ? kB64[v & 63] : '=';
  }
  const long before = rss_peak_kib(d.pid());
  auto c = d.client();
  auto r = encode_multipart(c, R"({"ui":{"png_base64":")" + b64 + "\"}}", tiny_exr());
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_EQ(error_code(r), "request.limit");
  EXPECT_NE(r.body.find("16384x8192"), std::string::npos) << r.body;
  EXPECT_LT(rss_peak_kib(d.pid()) - before, 64 * 1024) << "nothing was decoded";
}

// A request whose own estimate exceeds the budget is the client's (400 request.memory).
TEST(DaemonAbuse, ARequestLargerThanTheMemoryBudgetIsRefusedAtAdmission) {
  DaemonProcess d("[workers]\nmemory_budget_bytes = 67108864\n");
  REQUIRE_DAEMON(d);
  auto c = d.client();
  auto r = request(c, "POST", "/v1/pattern", R"({"pattern":"bt2111","width":1920,"height":1080})",
                   {{"Content-Type", "application/json"}});
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_EQ(error_code(r), "request.memory");
  r = request(c, "POST", "/v1/pattern", R"({"pattern":"bt2111","width":192,"height":108})",
              {{"Content-Type", "application/json"}});
  EXPECT_EQ(r.status, 200) << r.body;
}

// ---- 6. smaller defects ------------------------------------------------------------------------

TEST(DaemonAbuse, NulInABodyAndAnEmptyBase64UiAre400) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  auto c = d.client();
  std::string body = R"({"width":64})";
  body += '\0';
  body += "garbage";
  auto r = request(c, "POST", "/v1/render", body, {{"Content-Type", "application/json"}});
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_EQ(error_code(r), "request.syntax");
  r = encode_multipart(c, R"({"ui":{"png_base64":""}})", tiny_exr());
  EXPECT_EQ(r.status, 400) << r.body;
  EXPECT_EQ(error_code(r), "request.value");
}

// Temporaries of atomic writes left by a daemon killed mid-dump are removed at the next
// start, and the log says so; another file is kept, and a directory another running
// daemon holds is left alone.
TEST(DaemonAbuse, StaleDumpTemporariesAreRemovedAtStart) {
  TempDir mine;
  const fs::path dumps = mine / "dumps";
  fs::create_directories(dumps);
  for (const char* name : {".frame.png.tmp-0123456789ab", ".frame.json.tmp-fedcba987654"})
    std::ofstream(dumps / name) << "partial";
  std::ofstream(dumps / "frame.png") << "kept";
  std::ofstream(dumps / ".frame.png.tmp-notours") << "kept";
  {
    DaemonProcess d("", {"--dump-dir", dumps.string()});
    REQUIRE_DAEMON(d);
    EXPECT_FALSE(fs::exists(dumps / ".frame.png.tmp-0123456789ab"));
    EXPECT_FALSE(fs::exists(dumps / ".frame.json.tmp-fedcba987654"));
    EXPECT_TRUE(fs::exists(dumps / "frame.png"));
    EXPECT_TRUE(fs::exists(dumps / ".frame.png.tmp-notours"));
    EXPECT_NE(d.log().find("removed 2 stale temporary"), std::string::npos) << d.log();
    // A second daemon on the same dump directory does not touch the first one's files.
    std::ofstream(dumps / ".live.png.tmp-00000000beef") << "being written";
    DaemonProcess other("", {"--dump-dir", dumps.string()});
    REQUIRE_DAEMON(other);
    EXPECT_TRUE(fs::exists(dumps / ".live.png.tmp-00000000beef"));
    EXPECT_NE(other.log().find("in use by another hdrd"), std::string::npos) << other.log();
  }
}

// A daemon that stops removes its socket only if the path still holds the socket it made.
TEST(DaemonAbuse, StoppingLeavesAnotherDaemonsSocketAlone) {
  DaemonProcess d;
  REQUIRE_DAEMON(d);
  ASSERT_EQ(::unlink(d.socket().c_str()), 0);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::snprintf(a.sun_path, sizeof a.sun_path, "%s", d.socket().c_str());
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a), 0);
  ASSERT_EQ(::listen(fd, 4), 0);
  struct stat before{};
  ASSERT_EQ(::lstat(d.socket().c_str(), &before), 0);
  EXPECT_EQ(d.stop(SIGTERM), 0);
  struct stat after{};
  EXPECT_EQ(::lstat(d.socket().c_str(), &after), 0) << "the other socket was unlinked";
  EXPECT_EQ(after.st_ino, before.st_ino);
  ::close(fd);
}

// A full dump disk is 507 naming the directory (it was 500 io.write). Needs a small tmpfs,
// so root (as the CI container is); skipped with the reason otherwise.
TEST(DaemonAbuse, AFullDumpDiskIs507NamingTheDirectory) {
  TempDir mine;
  const fs::path full = mine / "full";
  fs::create_directories(full);
  if (::mount("tmpfs", full.c_str(), "tmpfs", 0, "size=64k") != 0)
    GTEST_SKIP() << "cannot mount a small tmpfs here (" << std::strerror(errno) << "); needs root";
  struct Unmount {
    fs::path p;
    ~Unmount() { ::umount2(p.c_str(), MNT_DETACH); }
  } unmount{full};
  {
    std::ofstream filler(full / "filler", std::ios::binary);
    const std::string block(4096, 'f');
    for (int i = 0; i < 64 && filler; ++i) filler.write(block.data(), std::streamsize(block.size()));
  }
  DaemonProcess d("", {"--dump-dir", full.string()});
  REQUIRE_DAEMON(d);
  auto c = d.client();
  auto r = request(c, "POST", "/v1/encode?mode=sdr&dump=true&name=f", tiny_exr(), {{"Content-Type", "image/x-exr"}});
  EXPECT_EQ(r.status, 507) << r.body;
  EXPECT_EQ(error_code(r), "io.no_space");
  EXPECT_NE(r.body.find(full.string()), std::string::npos) << r.body;
  for (const auto& e : fs::directory_iterator(full))
    EXPECT_EQ(e.path().filename(), "filler") << "no partial file left";
}

}  // namespace
}  // namespace hdrd::testing
