// hdrctl: the command-line client of `hdrd serve`. Subcommands mirror the API
// (docs/api.md): render, encode, displays, capabilities, status, metrics.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "daemon/client.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using hdrd::daemon::Client;
using hdrd::daemon::ClientOptions;
using hdrd::daemon::ClientResponse;

struct Failure {  // one line on stderr, then this exit status
  int exit_code;
  std::string message;
};

struct Global {
  std::string socket = hdrd::daemon::default_client_socket();
  std::string tcp, token_file;
  double timeout_s = 300;
  bool json = false;
  bool quiet = false;
};

// Options shared by render and encode: the request body, field by field.
struct FrameOptions {
  std::string request_file;
  std::optional<std::string> mode, range, sdr_curve, display, tonemap, tonemap_apply, exposure_mode, gamut, lut,
      lut_shaper, grade_placement, ui, ui_upload, name;
  std::optional<double> peak, black, paper_white, ui_white, sdr_white, exposure_ev, ev100, ui_scale, ui_dim;
  std::optional<int> bits;
  std::vector<std::string> tonemap_params, sets;
  std::vector<int> ui_pos;
  std::string output, format;
  bool dump = false;
  std::string dump_formats;
};

struct RenderOptions {
  FrameOptions frame;
  std::optional<std::string> scene, scene_file, gltf;
  std::optional<int> width, height, samples;
  std::vector<double> camera_position, camera_target;
  std::optional<double> fov;
};

struct EncodeOptions {
  FrameOptions frame;
  std::string input;
  std::optional<std::string> input_units;
};

std::string read_all(const std::string& path) {
  if (path == "-") {
    std::ostringstream ss;
    ss << std::cin.rdbuf();
    return ss.str();
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Failure{2, "cannot read " + path};
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string base64(const std::string& in) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  std::size_t i = 0;
  for (; i + 2 < in.size(); i += 3) {
    const unsigned v = (unsigned char)in[i] << 16 | (unsigned char)in[i + 1] << 8 | (unsigned char)in[i + 2];
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], k[v & 63]};
  }
  if (i + 1 == in.size()) {
    const unsigned v = (unsigned char)in[i] << 16;
    out += {k[v >> 18], k[(v >> 12) & 63], '=', '='};
  } else if (i + 2 == in.size()) {
    const unsigned v = (unsigned char)in[i] << 16 | (unsigned char)in[i + 1] << 8;
    out += {k[v >> 18], k[(v >> 12) & 63], k[(v >> 6) & 63], '='};
  }
  return out;
}

// --set a.b.c=VALUE: VALUE is JSON when it parses as JSON, else a string.
void apply_set(json& body, const std::string& assignment) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0) throw Failure{2, "--set expects key.path=value, got '" + assignment + "'"};
  std::string pointer = "/" + assignment.substr(0, eq);
  std::replace(pointer.begin(), pointer.end(), '.', '/');
  json value = json::parse(assignment.substr(eq + 1), nullptr, false);
  if (value.is_discarded()) value = assignment.substr(eq + 1);
  body[json::json_pointer(pointer)] = value;
}

json frame_body(const FrameOptions& o) {
  json b = o.request_file.empty() ? json::object() : json::parse(read_all(o.request_file), nullptr, false);
  if (b.is_discarded() || !b.is_object()) throw Failure{2, "--request: not a JSON object"};
  if (o.display && *o.display == "auto") b["display"] = "auto";
  auto set = [&](const char* ptr, const auto& v) {
    if (v) b[json::json_pointer(ptr)] = *v;
  };
  set("/display/mode", o.mode);
  set("/display/peak_nits", o.peak);
  set("/display/black_nits", o.black);
  set("/display/paper_white_nits", o.paper_white);
  set("/display/ui_white_nits", o.ui_white);
  set("/display/sdr_white_nits", o.sdr_white);
  set("/display/range", o.range);
  set("/display/bits", o.bits);
  set("/display/sdr_curve", o.sdr_curve);
  set("/tone/curve", o.tonemap);
  set("/tone/apply", o.tonemap_apply);
  for (const auto& kv : o.tonemap_params) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos) throw Failure{2, "--tonemap-param expects name=value"};
    b["tone"]["params"][kv.substr(0, eq)] = std::stod(kv.substr(eq + 1));
  }
  set("/exposure/mode", o.exposure_mode);
  set("/exposure_comp_ev", o.exposure_ev);
  set("/exposure/ev100", o.ev100);
  set("/gamut", o.gamut);
  set("/grade/lut", o.lut);
  set("/grade/shaper", o.lut_shaper);
  set("/grade/placement", o.grade_placement);
  set("/ui/path", o.ui);
  if (o.ui_upload) b["ui"]["png_base64"] = base64(read_all(*o.ui_upload));
  if (o.ui_pos.size() == 2) {
    b["ui"]["x"] = o.ui_pos[0];
    b["ui"]["y"] = o.ui_pos[1];
  }
  set("/ui/scale", o.ui_scale);
  set("/ui/dim", o.ui_dim);
  set("/name", o.name);
  if (o.dump) b["dump"] = true;
  if (!o.dump_formats.empty()) {
    json f = json::array();
    std::stringstream ss(o.dump_formats);
    for (std::string item; std::getline(ss, item, ',');) f.push_back(item);
    b["formats"] = f;
  }
  for (const auto& s : o.sets) apply_set(b, s);
  return b;
}

std::string accept_for(const FrameOptions& o) {
  if (o.dump) return "application/json";
  if (o.format.empty()) {
    const std::string ext = fs::path(o.output).extension().string();
    if (ext == ".exr") return "image/x-exr";
    if (ext == ".raw" || ext == ".bin") return "application/octet-stream";
    if (ext == ".png") return "image/png";
    return "image/png, image/x-exr;q=0.9";  // scrgb has no PNG form
  }
  if (o.format == "png") return "image/png";
  if (o.format == "exr") return "image/x-exr";
  if (o.format == "raw") return "application/octet-stream";
  throw Failure{2, "--format must be png, exr or raw"};
}

Client make_client(const Global& g) {
  ClientOptions co;
  co.socket_path = g.socket;
  co.tcp = g.tcp;
  co.timeout_s = g.timeout_s;
  if (!g.token_file.empty()) {
    std::string t = read_all(g.token_file);
    while (!t.empty() && (t.back() == '\n' || t.back() == '\r' || t.back() == ' ')) t.pop_back();
    co.token = t;
  }
  if (!g.quiet) {
    const bool tty = ::isatty(STDERR_FILENO);
    co.on_wait = [tty, last = 0](double s) mutable {
      if (s < 1.0 || int(s) == last) return;
      last = int(s);
      std::fprintf(stderr, tty ? "\rhdrctl: waiting for the daemon... %d s" : "hdrctl: waiting for the daemon... %d s\n",
                   last);
      std::fflush(stderr);
    };
  }
  return Client(co);
}

ClientResponse call(const Global& g, const std::string& method, const std::string& target, const std::string& body = {},
                    const std::vector<std::pair<std::string, std::string>>& headers = {}) {
  Client client = make_client(g);
  auto r = client.request(method, target, body, headers);
  if (!g.quiet && ::isatty(STDERR_FILENO)) std::fputs("\r\033[K", stderr);
  if (!r) throw Failure{3, r.error().message};
  if (r->status >= 400) {
    const auto e = r->error();
    if (g.json) std::fwrite(r->body.data(), 1, r->body.size(), stdout);
    throw Failure{1, fmt::format("{} ({}){}", e.message, e.code, e.field.empty() ? "" : ", field " + e.field)};
  }
  return std::move(*r);
}

void print(const std::string& s) {
  std::fwrite(s.data(), 1, s.size(), stdout);
  if (s.empty() || s.back() != '\n') std::fputc('\n', stdout);
}

void write_atomically(const std::string& path, const std::string& data) {
  const fs::path p(path);
  fs::path tmp = p;
  tmp += fmt::format(".tmp-{}", ::getpid());
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(data.data(), std::streamsize(data.size()));
    if (!out.flush()) {
      std::error_code ec;
      fs::remove(tmp, ec);
      throw Failure{1, "cannot write " + path};
    }
  }
  fs::rename(tmp, p);
}

// Writes the frame (or prints the dump JSON) and a summary of the X-Hdrd-* metadata.
void finish_frame(const Global& g, const FrameOptions& o, const ClientResponse& r) {
  json meta = json::object();
  for (const auto& [k, v] : r.headers)
    if (k.rfind("x-hdrd-", 0) == 0) meta[k.substr(7)] = v;
  meta["content_type"] = r.header("content-type") ? *r.header("content-type") : "";
  meta["bytes"] = r.body.size();
  if (o.dump) {
    print(r.body);
    return;
  }
  if (!o.output.empty() && o.output != "-") {
    write_atomically(o.output, r.body);
    meta["output"] = o.output;
  } else if (::isatty(STDOUT_FILENO)) {
    throw Failure{2, "refusing to write an image to a terminal: use -o FILE (or -o - to force stdout)"};
  } else {
    std::fwrite(r.body.data(), 1, r.body.size(), stdout);
  }
  const bool to_stdout = o.output.empty() || o.output == "-";
  auto get = [&](const char* k) { return meta.value(k, std::string("?")); };
  const std::string line = fmt::format(
      "{} {}x{} {} {} MaxCLL {} MaxFALL {} -> {} ({} bytes{}{})", get("mode"), get("width"), get("height"),
      get("fourcc"), meta["content_type"].get<std::string>(), get("maxcll"), get("maxfall"),
      to_stdout ? "stdout" : o.output, r.body.size(), meta.contains("render-ms") ? ", render " + get("render-ms") + " ms" : "",
      meta.contains("encode-ms") ? ", encode " + get("encode-ms") + " ms" : "");
  if (g.json && !to_stdout) print(meta.dump(2));
  else if (!g.quiet) std::fprintf(stderr, "hdrctl: %s\n", line.c_str());
}

void add_frame_options(CLI::App* app, FrameOptions& o) {
  app->add_option("--request", o.request_file, "JSON request body to start from (file, or - for stdin)");
  app->add_option("-o,--output", o.output, "Write the frame here (its extension picks the format)");
  app->add_option("--format", o.format, "png, exr or raw (DRM buffer); default from -o's extension, else png");
  app->add_option("--mode", o.mode, "hdr10, hlg, scrgb, sdr, sdr-bt1886");
  app->add_option("--display", o.display, "'auto': levels from the attached display");
  app->add_option("--peak", o.peak, "display.peak_nits");
  app->add_option("--black", o.black, "display.black_nits");
  app->add_option("--paper-white", o.paper_white, "display.paper_white_nits");
  app->add_option("--ui-white", o.ui_white, "display.ui_white_nits");
  app->add_option("--sdr-white", o.sdr_white, "display.sdr_white_nits");
  app->add_option("--range", o.range, "full or narrow");
  app->add_option("--bits", o.bits, "8 or 10 (SDR)");
  app->add_option("--sdr-curve", o.sdr_curve, "srgb or gamma22");
  app->add_option("--tonemap", o.tonemap, "Tone curve (hdrctl capabilities lists them)");
  app->add_option("--tonemap-param", o.tonemap_params, "Curve parameter name=value (repeatable)");
  app->add_option("--tonemap-apply", o.tonemap_apply, "per-channel, max-rgb, luminance, rgb");
  app->add_option("--exposure-mode", o.exposure_mode, "manual, camera, log-average, histogram, light");
  app->add_option("--exposure", o.exposure_ev, "Exposure compensation in EV (exposure_comp_ev)");
  app->add_option("--ev100", o.ev100, "Camera exposure EV100");
  app->add_option("--gamut", o.gamut, "ictcp or clip");
  app->add_option("--lut", o.lut, "3D LUT in the daemon's asset root");
  app->add_option("--lut-shaper", o.lut_shaper, "pq, log2, sqrt, sqrt-sqrt, none");
  app->add_option("--grade-placement", o.grade_placement, "scene, display, baked");
  app->add_option("--ui", o.ui, "UI PNG in the daemon's asset root");
  app->add_option("--ui-upload", o.ui_upload, "Local UI PNG, sent with the request");
  app->add_option("--ui-pos", o.ui_pos, "UI position X Y")->expected(2);
  app->add_option("--ui-scale", o.ui_scale, "UI scale");
  app->add_option("--ui-dim", o.ui_dim, "Darken the frame under the UI (0..1)");
  app->add_flag("--dump", o.dump, "Write the dump into the daemon's dump directory and print its sidecar");
  app->add_option("--dump-formats", o.dump_formats, "With --dump: png,exr,raw");
  app->add_option("--name", o.name, "With --dump: base name of the files");
  app->add_option("--set", o.sets, "Any request field: key.path=JSON (repeatable)");
}

void run_render(const Global& g, const RenderOptions& o) {
  json b = frame_body(o.frame);
  if (o.scene) b["scene"] = *o.scene;
  if (o.scene_file) b["scene_file"] = *o.scene_file;
  if (o.gltf) b["gltf"] = *o.gltf;
  if (o.width) b["width"] = *o.width;
  if (o.height) b["height"] = *o.height;
  if (o.samples) b["samples"] = *o.samples;
  if (o.camera_position.size() == 3) b["camera"]["position"] = o.camera_position;
  if (o.camera_target.size() == 3) b["camera"]["target"] = o.camera_target;
  if (o.fov) b["camera"]["fov_y_deg"] = *o.fov;
  const auto r = call(g, "POST", "/v1/render", b.dump(),
                      {{"Content-Type", "application/json"}, {"Accept", accept_for(o.frame)}});
  finish_frame(g, o.frame, r);
}

void run_encode(const Global& g, const EncodeOptions& o) {
  json b = frame_body(o.frame);
  if (o.input_units) b["input"] = *o.input_units;
  std::string content_type;
  const std::string body = hdrd::daemon::multipart_body(
      {{"image", fs::path(o.input).filename().string(), "image/x-exr", read_all(o.input)},
       {"request", "", "application/json", b.dump()}},
      &content_type);
  const auto r = call(g, "POST", "/v1/encode", body, {{"Content-Type", content_type}, {"Accept", accept_for(o.frame)}});
  finish_frame(g, o.frame, r);
}

void run_get(const Global& g, const std::string& path, bool text) {
  const auto r = call(g, "GET", path);
  if (text || g.json) {
    print(r.body);
    return;
  }
  json j = json::parse(r.body, nullptr, false);
  if (j.is_discarded()) {
    print(r.body);
    return;
  }
  if (path == "/v1/status") {
    print(fmt::format("hdrd {} up {:.0f} s on {}", j.value("version", "?"), j.value("uptime_s", 0.0),
                      j["listeners"].dump()));
    if (j.contains("renderer"))
      print(fmt::format("renderer: {}", j["renderer"].value("available", false)
                                            ? j["renderer"].value("backend", "") + " (" + j["renderer"].value("gl_renderer", "") + ")"
                                            : "not available"));
    if (j.contains("queue"))
      print(fmt::format("queue: {} waiting, {} running, capacity {}", j["queue"].value("depth", 0),
                        j["queue"].value("running", 0), j["queue"].value("capacity", 0)));
    return;
  }
  print(j.dump(2));
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hdrctl: client for the hdrd daemon (HTTP over its Unix socket; see docs/api.md)", "hdrctl"};
  app.require_subcommand(1);
  Global g;
  app.add_option("--socket", g.socket, "Daemon socket (default: $HDRD_SOCKET, $XDG_RUNTIME_DIR/hdrd.sock)");
  app.add_option("--tcp", g.tcp, "Connect over TCP host:port instead (needs --token-file)");
  app.add_option("--token-file", g.token_file, "Bearer token for TCP");
  app.add_option("--timeout", g.timeout_s, "Seconds to wait for an answer");
  app.add_flag("--json", g.json, "Machine-readable output on stdout");
  app.add_flag("-q,--quiet", g.quiet, "No progress on stderr");
  app.footer(
      "Examples:\n"
      "  hdrctl status\n"
      "  hdrctl render --width 256 --height 144 --mode hdr10 --peak 1000 -o frame.png\n"
      "  hdrctl render --scene material-grid --mode scrgb -o frame.exr\n"
      "  hdrctl render --mode sdr --dump --name grid\n"
      "  hdrctl encode ../shared/fixtures/exr/Desk.exr --mode sdr -o desk.png\n"
      "  hdrctl capabilities --json | jq '.tone_curves[].name'\n"
      "  hdrctl metrics");

  RenderOptions ro;
  auto* render = app.add_subcommand("render", "POST /v1/render: render a scene and fetch the encoded frame");
  add_frame_options(render, ro.frame);
  render->add_option("--scene", ro.scene, "Built-in scene name");
  render->add_option("--scene-file", ro.scene_file, "JSON scene in the daemon's asset root");
  render->add_option("--gltf", ro.gltf, "glTF file in the daemon's asset root");
  render->add_option("--width", ro.width, "Frame width");
  render->add_option("--height", ro.height, "Frame height");
  render->add_option("--samples", ro.samples, "MSAA samples");
  render->add_option("--camera-position", ro.camera_position, "Camera position X Y Z")->expected(3);
  render->add_option("--camera-target", ro.camera_target, "Camera target X Y Z")->expected(3);
  render->add_option("--fov", ro.fov, "Vertical field of view, degrees");
  render->footer("Examples:\n  hdrctl render --width 256 --height 144 --mode hdr10 --peak 1000 -o frame.png\n"
                 "  hdrctl render --request req.json --set display.mode=sdr -o frame.png");

  EncodeOptions eo;
  auto* encode = app.add_subcommand("encode", "POST /v1/encode: encode a local OpenEXR through the daemon");
  encode->add_option("file", eo.input, "OpenEXR file")->required();
  add_frame_options(encode, eo.frame);
  encode->add_option("--input", eo.input_units, "relative or absolute (default: from the file's whiteLuminance)");
  encode->footer("Examples:\n  hdrctl encode Desk.exr --mode hdr10 --peak 600 -o desk.png");

  auto* displays = app.add_subcommand("displays", "GET /v1/displays: attached displays and their HDR capabilities");
  auto* caps = app.add_subcommand("capabilities", "GET /v1/capabilities: modes, tone curves, limits");
  auto* status = app.add_subcommand("status", "GET /v1/status: version, uptime, renderer, queue");
  auto* metrics = app.add_subcommand("metrics", "GET /metrics: Prometheus text");
  for (auto* s : {displays, caps, status, metrics}) s->footer("Examples:\n  hdrctl " + s->get_name() + " --json");

  try {
    app.parse(argc, argv);
    if (*render) run_render(g, ro);
    else if (*encode) run_encode(g, eo);
    else if (*displays) run_get(g, "/v1/displays", false);
    else if (*caps) run_get(g, "/v1/capabilities", false);
    else if (*status) run_get(g, "/v1/status", false);
    else if (*metrics) run_get(g, "/metrics", true);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const Failure& f) {
    std::fprintf(stderr, "hdrctl: error: %s\n", f.message.c_str());
    return f.exit_code;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hdrctl: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
