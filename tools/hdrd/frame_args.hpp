// `render ARGS...` / `encode INPUT ARGS...` parsed as hdrd render / encode parse them (their
// options are the settings table's), for commands that take a sequence's request on their
// command line (hdrd sequence plan).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "job/settings.hpp"

namespace hdrd::cli {

struct FrameArgs {
  job::Source source = job::Source::render;
  nlohmann::json request;  // what a POST /v1/sequences body would hold; an encode's input as `images`
  bool sequence = false;   // it set a sequence setting or names a sequence of files
};

// Throws CliError / HdrdError with one line naming what is wrong.
FrameArgs parse_frame_args(const std::vector<std::string>& args);

}  // namespace hdrd::cli
