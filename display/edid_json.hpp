// JSON form of a parsed EDID (what `hdrd edid --json` and `hdrd displays --json` print).
// Keys are documented in docs/displays.md.
#pragma once

#include <nlohmann/json.hpp>

#include "display/edid.hpp"

namespace hdrd::display {

nlohmann::json edid_to_json(const EdidInfo& info);
nlohmann::json hdr_static_metadata_to_json(const HdrStaticMetadata& h);

// Colorimetry names that describe a colour encoding (edid-decode's names, without the
// MD0-MD3 gamut-metadata bits): "BT2020RGB", "ST2113RGB", "ICtCp", ...
std::vector<std::string> colorimetry_names(const Colorimetry& c);

}  // namespace hdrd::display
