// Fuzz target for the request parser (job/request.hpp) in all its spellings: JSON bodies of
// POST /v1/render, /v1/encode, /v1/pattern; query strings; CLI flag lists; Accept headers,
// base64 and paths inside an asset root (daemon/http/accept.hpp, daemon/api/paths.hpp). The first
// byte picks what the rest is fed to, the source, and whether it is a sequence request
// (POST /v1/sequences takes the sequence settings). Links only hdrd_daemon_request (and the pure request
// library under it).
//
// Invariants checked beyond "no crash": an accepted request is within the limits, its
// levels resolve to a valid target when no display is consulted, its paths lie inside the
// root, and its canonical JSON serialises; every error has a code, a status-table family
// and a one-line message.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "daemon/http/accept.hpp"
#include "daemon/api/paths.hpp"
#include "job/request.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hdrd;
using namespace hdrd::job;

// An asset root with a file, a directory and a symlink that leads out of it; removed at exit.
struct AssetRoot {
  fs::path base;
  ~AssetRoot() {
    std::error_code ec;
    fs::remove_all(base, ec);
  }
};

const fs::path& asset_root() {
  static AssetRoot holder;
  static const fs::path root = [] {
    const fs::path base = fs::temp_directory_path() / ("hdrd-request-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(base / "assets/scenes");
    std::ofstream(base / "assets/scenes/a.json") << "{}";
    std::ofstream(base / "assets/grade.cube") << "LUT_3D_SIZE 2\n";
    std::ofstream(base / "outside.txt") << "x";
    std::error_code ec;
    fs::create_symlink(base / "outside.txt", base / "assets/escape.gltf", ec);
    holder.base = base;
    return base / "assets";
  }();
  return root;
}

void check(bool ok) {
  if (!ok) std::abort();
}

void check_error(const Error& e) {
  check(!e.code.empty());
  check(!e.message.empty());
  check(e.message.find('\n') == std::string::npos);
}

void check_request(const Result<FrameRequest>& r, const ParseContext& ctx) {
  if (!r) {
    check_error(r.error());
    return;
  }
  if (r->source != Source::encode) {
    check(r->integer("width") >= 1 && r->integer("width") <= ctx.limits.max_width);
    check(r->integer("height") >= 1 && r->integer("height") <= ctx.limits.max_height);
    check(r->integer("width") * r->integer("height") <= ctx.limits.max_pixels);
  }
  if (r->source == Source::render) check(r->integer("samples") >= 1 && r->integer("samples") <= ctx.limits.max_samples);
  if (r->is_null("display.connector") && r->is_null("display.edid") && r->is_null("display.profile")) {
    const auto mode = parse_mode(r->text("display.mode")).value_or(Mode::hdr10);
    check(resolve_target(mode, {}, request_levels(*r)).ok());
  }
  for (const auto& s : settings())
    if (s.type == Type::path && s.takes(r->source) && (r->sequence || !s.sequence) && !r->is_null(s.path))
      check(daemon::is_within(fs::canonical(asset_root()), r->text(s.path)));
  (void)r->canonical().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string accept = "image/png, image/x-exr;q=0.5";
  (void)daemon::negotiate_output(&accept, parse_mode(r->text("display.mode")).value_or(Mode::hdr10));
}

std::vector<std::pair<std::string, std::string>> split_pairs(const std::string& rest, char sep, char eqc) {
  std::vector<std::pair<std::string, std::string>> q;
  std::size_t start = 0;
  while (start <= rest.size() && q.size() < 64) {
    const std::size_t amp = rest.find(sep, start);
    const std::string item = rest.substr(start, amp == std::string::npos ? std::string::npos : amp - start);
    const std::size_t eq = item.find(eqc);
    q.emplace_back(item.substr(0, eq), eq == std::string::npos ? "" : item.substr(eq + 1));
    if (amp == std::string::npos) break;
    start = amp + 1;
  }
  return q;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string rest(reinterpret_cast<const char*>(data) + 1, size - 1);
  ParseContext ctx;
  ctx.reach = Reach::daemon;
  ctx.limits.max_body_bytes = 1 << 20;
  ctx.resolve_path = [](std::string_view p, const std::string& field) {
    return daemon::resolve_in_root(asset_root(), p, field);
  };
  const Source sources[] = {Source::render, Source::encode, Source::pattern};
  ctx.source = sources[(data[0] >> 3) % 3];
  ctx.sequence = (data[0] >> 3) / 3 % 2 == 1;  // POST /v1/sequences: the sequence settings too
  switch (data[0] % 8) {
    case 0:
    case 1:
    case 5:  // a JSON body
      check_request(parse_request(rest, ctx), ctx);
      break;
    case 2: {  // a query string: k=v&k=v
      auto j = query_to_request_json(split_pairs(rest, '&', '='));
      if (!j) {
        check_error(j.error());
        break;
      }
      ctx.spelling = Spelling::query;
      check_request(parse_request_json(*j, ctx), ctx);
      break;
    }
    case 3: {  // an Accept header
      for (Mode m : {Mode::hdr10, Mode::scrgb}) {
        auto k = daemon::negotiate_output(&rest, m);
        if (!k) check_error(k.error());
        else if (m == Mode::scrgb) check(*k != Output::png);
      }
      if (auto j = daemon::accepts_json(&rest); !j) check_error(j.error());
      break;
    }
    case 4: {  // base64 and paths
      auto b = decode_base64(rest, 4096);
      if (b) check(b->size() <= 4096);
      auto p = daemon::resolve_in_root(asset_root(), rest, "f");
      if (p) check(daemon::is_within(fs::canonical(asset_root()), *p));
      else check_error(p.error());
      break;
    }
    case 6: {  // CLI flags: --flag value pairs, as tools/common/settings_cli.cpp hands them over
      auto j = cli_to_request_json(split_pairs(rest, '\n', ' '));
      if (!j) {
        check_error(j.error());
        break;
      }
      ctx.spelling = Spelling::cli;
      ctx.reach = Reach::cli;
      ctx.resolve_path = [](std::string_view p, const std::string&) -> Result<fs::path> { return fs::path(p); };
      auto r = parse_request_json(*j, ctx);
      if (!r) check_error(r.error());
      else (void)r->canonical().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      break;
    }
    case 7:
      break;
  }
  return 0;
}
