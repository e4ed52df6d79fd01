// hdrctl's request options and the JSON bodies they make. The request settings are the
// settings table's (job/settings.hpp), exactly as `hdrd render/encode/pattern` offers them
// (tools/common/settings_cli.hpp); hdrctl adds only its transport: a request file to start
// from, --set overrides, where the answer goes and in what format, dumps.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "job/settings.hpp"
#include "tools/common/settings_cli.hpp"

namespace hdrctl {

struct Failure {  // one line on stderr, then this exit status
  int exit_code;
  std::string message;
};

// Where the answer goes, and the request file / --set overrides every body starts from.
struct OutputOptions {
  std::string request_file;
  std::vector<std::string> sets;
  std::string output;
  std::string format;  // without --dump: the reply's format (png, exr, raw); with --dump: the dump's formats
  bool dump = false;
  std::optional<std::string> name;
};

struct FrameOptions {
  hdrd::cli::SettingArgs settings;
  OutputOptions out;
  std::string ui_upload;  // a local PNG sent in the request (ui.png_base64)
};

// hdrctl sequence render|encode: a sequence request (POST /v1/sequences) and what to do
// with the job: follow it with a progress bar, download its result, or only print its id.
struct SequenceOptions {
  hdrd::job::Source source = hdrd::job::Source::render;
  hdrd::cli::SettingArgs settings;
  std::string request_file;
  std::vector<std::string> sets;
  std::string images;       // encode: a pattern, directory or list file in the daemon's asset root
  std::string output;       // download the result (the video, else the sidecar) here
  std::string formats;      // per-frame dumps (png,exr,raw,...)
  std::optional<std::string> name;
  bool detach = false;
  bool keep = false;        // with -o: leave the job's files in the dump directory after downloading
  double poll_s = 0.25;
};

std::string read_all(const std::string& path);  // "-": stdin

// The settings of `source` as options, and hdrctl's transport options.
void add_frame_options(CLI::App* app, hdrd::job::Source source, FrameOptions& o);

// The request body: the --request file, then the setting options, then `extra` (a pattern's
// name), then every --set.
nlohmann::json frame_body(const FrameOptions& o, const nlohmann::json& extra = nlohmann::json::object());

// The settings of `source` (sequence settings included) and hdrctl's sequence options.
void add_sequence_options(CLI::App* app, SequenceOptions& o);

// The POST /v1/sequences body: the --request file, the setting options, source, images,
// formats and name, then every --set.
nlohmann::json sequence_body(const SequenceOptions& o);

// The Accept header for the answer: JSON for a dump, else from --format or -o's extension.
std::string accept_for(const OutputOptions& o);

}  // namespace hdrctl
