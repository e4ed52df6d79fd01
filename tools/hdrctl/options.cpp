#include "tools/hdrctl/options.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <fmt/format.h>

#include "job/outputs.hpp"

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

std::string format_help() {
  std::string ext;
  for (auto e : hdrd::job::output_extensions()) ext += (ext.empty() ? "" : " ") + std::string(e);
  std::string dump;
  for (auto n : hdrd::job::output_names()) dump += (dump.empty() ? "" : ",") + std::string(n);
  return fmt::format("The answer's format: {}; default from -o's extension ({}), else png. With --dump: the dump's "
                     "formats, a list of {}",
                     hdrd::job::reply_output_names(), ext, dump);
}

std::string sequence_format_help() {
  std::string names;
  for (auto n : hdrd::job::output_names()) names += (names.empty() ? "" : ",") + std::string(n);
  return "Per-frame dumps beside the video (OUTBASE.NNNNN.EXT), a list of " + names;
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

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

std::string read_all(const std::string& path) {
  if (path == "-") {
    std::ostringstream ss;
    ss << std::cin.rdbuf();
    return ss.str();
  }
  std::ifstream f(path, std::ios::binary);
  if (!f) throw Failure{2, "cannot read " + path};
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

void add_frame_options(CLI::App* app, hdrd::job::Source source, FrameOptions& o) {
  auto& out = o.out;
  app->add_option("--request", out.request_file, "JSON request body to start from (file, or - for stdin)");
  app->add_option("--set", out.sets, "Any request field: key.path=JSON (repeatable)");
  app->add_option("-o,--output", out.output, "Write the frame here (its extension picks the format)");
  app->add_option("--format", out.format, format_help());
  app->add_flag("--dump", out.dump, "Write the dump into the daemon's dump directory and print its sidecar");
  app->add_option("--name", out.name, "With --dump: base name of the files");
  if (source != hdrd::job::Source::pattern)
    app->add_option("--ui-upload", o.ui_upload, "A local UI PNG, sent with the request (ui.png_base64)")
        ->group("UI overlay");
  hdrd::cli::add_setting_options(*app, source, hdrd::job::Reach::daemon, o.settings, {"--format"});
}

json frame_body(const FrameOptions& o, const json& extra) {
  json b = o.out.request_file.empty() ? json::object() : json::parse(read_all(o.out.request_file), nullptr, false);
  if (b.is_discarded() || !b.is_object()) throw Failure{2, "--request: not a JSON object"};
  auto settings = hdrd::cli::request_json(o.settings);
  if (!settings) throw Failure{2, settings.error().message};
  b.merge_patch(*settings);
  if (!o.ui_upload.empty()) b["ui"]["png_base64"] = base64(read_all(o.ui_upload));
  if (o.out.dump) {
    b["dump"] = true;
    if (o.out.name) b["name"] = *o.out.name;
    if (!o.out.format.empty()) b["formats"] = split(o.out.format);
  } else if (o.out.name) {
    throw Failure{2, "--name names a dump: use it with --dump"};
  }
  b.update(extra, true);
  for (const auto& s : o.out.sets) apply_set(b, s);
  return b;
}

void add_sequence_options(CLI::App* app, SequenceOptions& o) {
  app->add_option("--request", o.request_file, "JSON request body to start from (file, or - for stdin)");
  app->add_option("--set", o.sets, "Any request field: key.path=JSON (repeatable)");
  app->add_option("-o,--output", o.output,
                  "When the job is done, download its video (else its sidecar) here, then remove the job's files "
                  "from the daemon's dump directory");
  app->add_flag("--keep", o.keep, "With -o: keep the job's files in the daemon's dump directory after downloading");
  app->add_option("--format", o.formats, sequence_format_help());
  app->add_option("--name", o.name, "Base name of the files in the daemon's dump directory (default: generated)");
  app->add_flag("--detach", o.detach, "Print the job's id and return (follow it with hdrctl jobs show ID)");
  app->add_option("--poll", o.poll_s, "Seconds between progress polls")->check(CLI::Range(0.02, 60.0));
  hdrd::cli::add_setting_options(*app, o.source, hdrd::job::Reach::daemon, o.settings, {"--format"});
}

json sequence_body(const SequenceOptions& o) {
  json b = o.request_file.empty() ? json::object() : json::parse(read_all(o.request_file), nullptr, false);
  if (b.is_discarded() || !b.is_object()) throw Failure{2, "--request: not a JSON object"};
  auto settings = hdrd::cli::request_json(o.settings);
  if (!settings) throw Failure{2, settings.error().message};
  b.merge_patch(*settings);
  b["source"] = std::string(hdrd::job::to_string(o.source));
  if (!o.images.empty()) b["images"] = o.images;
  if (!o.formats.empty()) b["formats"] = split(o.formats);
  if (o.name) b["name"] = *o.name;
  for (const auto& s : o.sets) apply_set(b, s);
  return b;
}

std::string accept_for(const OutputOptions& o) {
  if (o.dump) return "application/json";
  std::string name = o.format;
  if (name.empty()) {
    // No extension (-o frame, -o -): the daemon's default, PNG (scrgb has no PNG form: EXR).
    const std::string ext = o.output == "-" ? "" : fs::path(o.output).extension().string();
    if (ext.empty()) return "image/png, image/x-exr;q=0.9";
    const auto* by_ext = hdrd::job::output_for_extension(ext);
    if (!by_ext) {
      std::string known;
      for (auto e : hdrd::job::output_extensions()) known += (known.empty() ? "" : ", ") + std::string(e);
      throw Failure{2, fmt::format("-o {}: no format is written as '{}' (known: {}); or name one with --format",
                                   o.output, ext, known)};
    }
    return std::string(by_ext->content_type);
  }
  const auto* out = hdrd::job::find_output(name);
  if (!out || !out->reply)
    throw Failure{2, "--format (or -o's extension) must be one of " + hdrd::job::reply_output_names() + " without --dump"};
  return std::string(out->content_type);
}


}  // namespace hdrctl
