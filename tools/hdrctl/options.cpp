#include "tools/hdrctl/options.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace hdrctl {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

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

// Sets body[ptr] when the option was given.
template <class T>
void set_if(json& b, const char* ptr, const std::optional<T>& v) {
  if (v) b[json::json_pointer(ptr)] = *v;
}

json start_body(const OutputOptions& o) {
  json b = o.request_file.empty() ? json::object() : json::parse(read_all(o.request_file), nullptr, false);
  if (b.is_discarded() || !b.is_object()) throw Failure{2, "--request: not a JSON object"};
  return b;
}

void set_display(json& b, const DisplayOptions& o) {
  if (o.display && *o.display == "auto") b["display"] = "auto";
  else if (o.display) throw Failure{2, "--display takes 'auto' (or use --mode, --peak, ...)"};
  set_if(b, "/display/mode", o.mode);
  set_if(b, "/display/peak_nits", o.peak);
  set_if(b, "/display/black_nits", o.black);
  set_if(b, "/display/paper_white_nits", o.paper_white);
  set_if(b, "/display/ui_white_nits", o.ui_white);
  set_if(b, "/display/sdr_white_nits", o.sdr_white);
  set_if(b, "/display/range", o.range);
  set_if(b, "/display/bits", o.bits);
  set_if(b, "/display/sdr_curve", o.sdr_curve);
}

void set_pipeline(json& b, const PipelineOptions& o) {
  set_if(b, "/tone/curve", o.tonemap);
  set_if(b, "/tone/apply", o.tonemap_apply);
  for (const auto& kv : o.tonemap_params) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos) throw Failure{2, "--tonemap-param expects name=value, got '" + kv + "'"};
    try {
      b["tone"]["params"][kv.substr(0, eq)] = std::stod(kv.substr(eq + 1));
    } catch (const std::exception&) {
      throw Failure{2, "--tonemap-param " + kv + ": the value is not a number"};
    }
  }
  set_if(b, "/exposure/mode", o.exposure_mode);
  set_if(b, "/exposure_comp_ev", o.exposure_ev);
  set_if(b, "/exposure/ev100", o.ev100);
  set_if(b, "/gamut", o.gamut);
  set_if(b, "/grade/lut", o.lut);
  set_if(b, "/grade/shaper", o.lut_shaper);
  set_if(b, "/grade/placement", o.grade_placement);
  set_if(b, "/ui/path", o.ui);
  if (o.ui_upload) b["ui"]["png_base64"] = base64(read_all(*o.ui_upload));
  if (o.ui_pos.size() == 2) {
    b["ui"]["x"] = o.ui_pos[0];
    b["ui"]["y"] = o.ui_pos[1];
  }
  set_if(b, "/ui/scale", o.ui_scale);
  set_if(b, "/ui/dim", o.ui_dim);
}

void set_output(json& b, const OutputOptions& o) {
  set_if(b, "/name", o.name);
  if (o.dump) b["dump"] = true;
  if (!o.dump_formats.empty()) {
    json f = json::array();
    std::stringstream ss(o.dump_formats);
    for (std::string item; std::getline(ss, item, ',');) f.push_back(item);
    b["formats"] = f;
  }
}

void apply_sets(json& b, const OutputOptions& o) {
  for (const auto& s : o.sets) apply_set(b, s);
}

}  // namespace

std::string read_all(const std::string& path) {
  std::ostringstream ss;
  if (path == "-") {
    ss << std::cin.rdbuf();
    return ss.str();
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Failure{2, "cannot read " + path};
  ss << in.rdbuf();
  return ss.str();
}

void add_display_options(CLI::App* app, DisplayOptions& o) {
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
}

void add_pipeline_options(CLI::App* app, PipelineOptions& o) {
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
}

void add_output_options(CLI::App* app, OutputOptions& o) {
  app->add_option("--request", o.request_file, "JSON request body to start from (file, or - for stdin)");
  app->add_option("--set", o.sets, "Any request field: key.path=JSON (repeatable)");
  app->add_option("-o,--output", o.output, "Write the frame here (its extension picks the format)");
  app->add_option("--format", o.format, "png, exr or raw (DRM buffer); default from -o's extension, else png");
  app->add_flag("--dump", o.dump, "Write the dump into the daemon's dump directory and print its sidecar");
  app->add_option("--dump-formats", o.dump_formats, "With --dump: png,exr,raw");
  app->add_option("--name", o.name, "With --dump: base name of the files");
}

void add_pattern_options(CLI::App* app, PatternOptions& o) {
  app->add_option("name", o.name, "bt2111, pq-ramp, window, near-black, clipping, sdr-grey (--list)");
  app->add_flag("--list", o.list, "List the patterns and their parameters (from the daemon)");
  app->add_option("--width", o.width, "Width in pixels (default 1920)");
  app->add_option("--height", o.height, "Height in pixels (default 1080)");
  app->add_option("--level", o.level, "window, clipping: params.level_nits (default: the display peak)");
  app->add_option("--area", o.area, "window: params.area_percent (default 10)");
  app->add_option("--steps", o.steps, "pq-ramp, sdr-grey: steps (default 11); near-black: levels (at most 10)");
  app->add_flag("--no-labels", o.no_labels, "pq-ramp, near-black, clipping, sdr-grey: no labels");
}

json frame_body(const FrameOptions& o, const json& extra) {
  json b = start_body(o.out);
  set_display(b, o.display);
  set_pipeline(b, o.pipeline);
  set_output(b, o.out);
  b.update(extra, true);
  apply_sets(b, o.out);
  return b;
}

json pattern_body(const PatternOptions& o) {
  json b = start_body(o.out);
  b["pattern"] = o.name;
  set_display(b, o.display);
  set_if(b, "/width", o.width);
  set_if(b, "/height", o.height);
  set_if(b, "/params/level_nits", o.level);
  set_if(b, "/params/area_percent", o.area);
  set_if(b, "/params/steps", o.steps);
  if (o.no_labels) b["params"]["labels"] = false;
  set_output(b, o.out);
  apply_sets(b, o.out);
  return b;
}

std::string accept_for(const OutputOptions& o) {
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

}  // namespace hdrctl
