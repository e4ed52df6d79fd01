// The files of a sequence, named the three ways a user names one (docs/sequences.md
// "Inputs"): a printf pattern ("shot.%04d.exr": every number that exists, from the lowest,
// consecutive; a gap is an error naming the missing frame; %04d matches what printf writes,
// at least 4 digits and no extra leading zero), a directory (its files of one extension, in
// name order) or a list file (.txt, .lst, .list: one path per line, relative to the list's
// directory; blank lines and '#' comments skipped). hdrd encode's EXR sequences and hdrd
// present's dump sequences both read them here.
#pragma once

#include <filesystem>
#include <functional>
#include <string_view>
#include <vector>

#include "encode/io/beneath.hpp"
#include "encode/result.hpp"

namespace hdrd::io {

struct FileSequenceRules {
  std::string_view code = "input.sequence";  // the error code
  std::string_view field = "images";         // the setting errors name
  std::string_view extension = ".exr";       // a directory's members (any case)
  // A directory's member must also pass this (e.g. a dump's sidecar needs its .raw); unset: any.
  std::function<bool(const std::filesystem::path&)> accept;
  std::string_view what = ".exr file";       // for "the directory holds no ..."
  std::size_t max_files = 1000000;
  InputFiles files;  // where a list file is opened (encode/io/beneath.hpp)
};

bool is_frame_pattern(const std::filesystem::path& spec);  // its file name holds one %d / %0Nd
bool is_list_file(const std::filesystem::path& spec);      // .txt, .lst, .list
// A pattern, a directory or a list file: what only a sequence can be.
bool names_a_file_sequence(const std::filesystem::path& spec);

// The files, in order. A spec that is none of the three is an error.
Result<std::vector<std::filesystem::path>> file_sequence(const std::filesystem::path& spec,
                                                         const FileSequenceRules& rules = {});

}  // namespace hdrd::io
