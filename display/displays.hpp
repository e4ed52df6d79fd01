// What is attached: every DRM device's connectors with their state, modes, EDID, the
// HDR-related properties (HDR_OUTPUT_METADATA, Colorspace, max bpc) and the derived
// profile. Headless machines have no DRM devices: an empty report with a note.
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "display/edid.hpp"
#include "display/kms.hpp"
#include "display/profile.hpp"
#include "encode/result.hpp"

namespace hdrd::display {

struct ConnectorReport {
  std::string device;
  std::string driver;
  kms::Connector connector;
  std::optional<EdidInfo> edid;
  std::optional<std::string> edid_error;
  std::optional<Profile> profile;       // from the EDID, with matching overrides applied
  bool has_hdr_output_metadata = false;
  std::vector<std::string> colorspaces;  // entries of the Colorspace enum, empty when absent
  std::optional<std::pair<std::uint64_t, std::uint64_t>> max_bpc_range;
  std::optional<std::uint64_t> max_bpc;
  bool connected() const { return connector.status == kms::ConnectionStatus::connected; }
  // Can hdrd send HDR here: an HDR profile and the properties to signal it.
  bool hdr_capable() const;
};

struct DisplaysReport {
  std::vector<std::string> devices;
  std::vector<ConnectorReport> connectors;
  std::vector<std::string> errors;  // devices that could not be read, one line each
  std::string note;                 // e.g. "no DRM devices (headless)"
};

// Connectors of one device (writeback connectors skipped).
Result<std::vector<ConnectorReport>> describe_connectors(kms::KmsDevice& device,
                                                         const std::vector<ProfileOverride>& overrides = {});

// Every DRM device on this machine, via libdrm.
DisplaysReport enumerate_displays(const std::vector<ProfileOverride>& overrides = {});

// The first connected connector that can take HDR, else the first connected display at
// all (an SDR monitor gets its SDR profile rather than HDR defaults); nullopt when nothing
// is connected or there are no DRM devices (headless). Overrides from
// default_profile_dirs() are applied.
Result<std::optional<Profile>> auto_profile();
// The same choice over an already-built report (testable without libdrm).
std::optional<Profile> choose_auto_profile(const DisplaysReport& report);

nlohmann::json to_json(const ConnectorReport& c);
nlohmann::json to_json(const DisplaysReport& r);

// The profile a --display / --edid pair selects (what `hdrd encode`/`render` and requests
// use): --edid FILE wins; --display auto = auto_profile(); --display NAME = that connector;
// "" and "" select nothing (nullopt). Matching overrides from default_profile_dirs() are
// applied, then `override_file` (named by the user, so applied without [match]).
// --display auto on a headless machine is nullopt, not an error: the caller keeps its
// defaults and should say so.
// `files`: where edid_path and override_file are opened (encode/io/beneath.hpp).
Result<std::optional<Profile>> select_profile(const std::string& display, const std::string& edid_path,
                                              const std::string& override_file = "", const io::InputFiles& files = {});

// Loads every override in default_profile_dirs(); unreadable files are errors.
Result<std::vector<ProfileOverride>> load_default_overrides();

}  // namespace hdrd::display
