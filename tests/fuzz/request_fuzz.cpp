// Fuzz target for the daemon's request parsing and validation (daemon/request.hpp):
// JSON bodies for POST /v1/render, /v1/encode, /v1/pattern and /v1/selftest, query
// strings, Accept headers, base64 and paths inside an asset root. The first byte picks what the rest is fed to. Links only
// hdrd_daemon_request (and the encode pieces it validates with).
//
// Invariants checked beyond "no crash": an accepted request is within the limits, has a
// valid display target, and its canonical JSON serialises; every error has a code and a
// one-line message.
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "daemon/output.hpp"
#include "daemon/paths.hpp"
#include "daemon/pattern_catalogue.hpp"
#include "daemon/request.hpp"

namespace {

namespace fs = std::filesystem;
using namespace hdrd;
using namespace hdrd::daemon;

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

void check_request(const Result<Request>& r, const ParseContext& ctx) {
  if (!r) {
    check_error(r.error());
    return;
  }
  if (r->endpoint == Endpoint::pattern) {
    check(find_pattern_entry(r->pattern.name) != nullptr);
    check(r->width >= 1 && r->width <= ctx.limits.max_width);
    check(r->height >= 1 && r->height <= ctx.limits.max_height);
  }
  if (r->endpoint == Endpoint::render) {
    check(r->width >= 1 && r->width <= ctx.limits.max_width);
    check(r->height >= 1 && r->height <= ctx.limits.max_height);
    check(std::int64_t(r->width) * r->height <= ctx.limits.max_pixels);
    check(r->samples >= 1 && r->samples <= ctx.limits.max_samples);
  }
  check(validate(r->display.target).ok());
  for (const auto* p : {&r->scene.path, r->grade ? &r->grade->lut : nullptr, r->ui ? &r->ui->path : nullptr})
    if (p && !p->empty()) check(is_within(fs::canonical(ctx.asset_root), *p));
  if (!r->name.empty()) check(validate_dump_name(r->name).ok());
  (void)r->canonical().dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string accept = "image/png, image/x-exr;q=0.5";
  (void)negotiate_output(&accept, r->display.target.mode, r->dump);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string rest(reinterpret_cast<const char*>(data) + 1, size - 1);
  ParseContext ctx;
  ctx.asset_root = asset_root();
  ctx.limits.max_body_bytes = 1 << 20;
  switch (data[0] % 8) {
    case 0:
    case 1: {  // a render or encode body
      ctx.endpoint = data[0] % 5 == 0 ? Endpoint::render : Endpoint::encode;
      check_request(parse_request(rest, ctx), ctx);
      break;
    }
    case 2: {  // a query string: k=v&k=v
      std::vector<std::pair<std::string, std::string>> q;
      std::size_t start = 0;
      while (start <= rest.size() && q.size() < 64) {
        const std::size_t amp = rest.find('&', start);
        const std::string item = rest.substr(start, amp == std::string::npos ? std::string::npos : amp - start);
        const std::size_t eq = item.find('=');
        q.emplace_back(item.substr(0, eq), eq == std::string::npos ? "" : item.substr(eq + 1));
        if (amp == std::string::npos) break;
        start = amp + 1;
      }
      auto j = query_to_request_json(q);
      if (!j) {
        check_error(j.error());
        break;
      }
      ctx.endpoint = Endpoint::encode;
      check_request(parse_request_json(*j, ctx), ctx);
      break;
    }
    case 3: {  // an Accept header
      for (Mode m : {Mode::hdr10, Mode::scrgb})
        for (bool dump : {false, true}) {
          auto k = negotiate_output(&rest, m, dump);
          if (!k) check_error(k.error());
          else if (m == Mode::scrgb && !dump) check(*k != OutputKind::png);
        }
      break;
    }
    case 4: {  // base64 and paths
      auto b = decode_base64(rest, 4096);
      if (b) check(b->size() <= 4096);
      auto p = resolve_in_root(asset_root(), rest, "f");
      if (p) check(is_within(fs::canonical(asset_root()), *p));
      else check_error(p.error());
      break;
    }
    case 5: {  // a pattern body
      ctx.endpoint = Endpoint::pattern;
      check_request(parse_request(rest, ctx), ctx);
      break;
    }
    case 6: {  // a selftest body
      auto r = parse_selftest_request(rest, ctx);
      if (!r) check_error(r.error());
      else (void)r->canonical().dump();
      break;
    }
  }
  return 0;
}
