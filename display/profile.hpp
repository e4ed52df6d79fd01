// Display profiles: what the encoder should target for a given display, derived from its
// EDID (CTA-861 HDR Static Metadata, Colorimetry, DisplayID 2.0 parameters) with
// documented fallbacks, optionally overridden from a TOML/JSON file or a request.
// docs/displays.md explains every rule and fallback.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "display/edid.hpp"
#include "encode/colour/color.hpp"
#include "encode/display_target.hpp"
#include "encode/io/beneath.hpp"
#include "encode/result.hpp"

namespace hdrd::display {

// Fallbacks, named so docs and tests can cite them.
inline constexpr double kFallbackHdrPeakNits = 1000.0;   // REFERENCE.md §1.8 hdr10/hlg default
inline constexpr double kFallbackSdrPeakNits = 100.0;    // REFERENCE.md §1.8 SDR white
inline constexpr double kFallbackBt709MonitorPeakNits = 400.0;  // VESA DisplayHDR 400, the lowest HDR class
inline constexpr int kMaxMonitorWidthCm = 80;                   // wider (or size unknown): a TV-class panel
inline constexpr double kMinPlausibleHdrPeakNits = 100.0;  // below SDR reference white: not an HDR claim
inline constexpr double kMaxPqNits = 10000.0;            // SMPTE ST 2084 ceiling

struct Profile {
  Mode mode = Mode::sdr;
  double peak_nits = kFallbackSdrPeakNits;        // desired content max luminance
  double frame_average_nits = kFallbackSdrPeakNits;  // desired content max frame-average luminance
  double black_nits = 0.1;                        // desired content min luminance
  color::Primaries primaries = color::kRec709;    // the display's own primaries (EDID)
  std::string name;                               // display product name ("" when unknown)
  std::string manufacturer;                       // PNP ID, e.g. "DEL"
  std::uint16_t product_code = 0;

  // What the display signals, whatever mode was chosen.
  bool signals_pq = false;
  bool signals_hlg = false;
  bool signals_bt2020_rgb = false;
  bool hdr10plus = false;

  std::string mode_reason;          // one line: why this mode
  std::vector<std::string> notes;   // every fallback and override applied, one line each
  std::string source = "defaults";  // "edid:<name>", then "+override:<where>" per override

  bool is_hdr() const { return mode == Mode::hdr10 || mode == Mode::hlg; }
};

// Profile of a parsed EDID. Never fails: missing or absurd values fall back (see notes).
Profile profile_from_edid_info(const EdidInfo& info);
Result<Profile> profile_from_edid(std::span<const std::uint8_t> edid);
Result<Profile> profile_from_edid_file(const std::filesystem::path& path, const io::InputFiles& files = {});

// Reads a whole (small) binary file, e.g. an EDID, opened through `files` (encode/io/beneath.hpp:
// beneath the daemon's asset root, or as given; never waiting on a FIFO); errors name the path.
Result<std::vector<std::uint8_t>> read_binary_file(const std::filesystem::path& path,
                                                   std::size_t max_bytes = 64 * 1024, const io::InputFiles& files = {});

// What the profile says about the levels (peak, black, the display's primaries) for the
// levels resolver (encode/display_target.hpp resolve_target), which adds the mode's
// defaults, the request's values and the one coupling rule for the whites.
LevelSettings profile_levels(const Profile& profile);

// The target for the profile alone: its mode and levels, everything else the mode's.
DisplayTarget target_for_profile(const Profile& profile);

Result<void> validate_profile(const Profile& profile);

nlohmann::json profile_to_json(const Profile& profile);

// ---- Overrides (config/profiles/*.toml|*.json and per request) -----------------------
// File layout (TOML; JSON has the same keys):
//   [match]   manufacturer = "DEL"  product_code = 41194  name = "DELL U2718Q"
//   [profile] mode = "hdr10"  peak_nits = 400  frame_average_nits = 350  black_nits = 0.3
//             name = "..."  primaries = "p3" | { red = [x, y], green = [...], blue = [...], white = [...] }
struct ProfileOverride {
  std::optional<std::string> match_manufacturer;
  std::optional<std::uint16_t> match_product_code;
  std::optional<std::string> match_name;

  std::optional<Mode> mode;
  std::optional<double> peak_nits, frame_average_nits, black_nits;
  std::optional<color::Primaries> primaries;
  std::optional<std::string> name;
  std::string source;  // file path or "request"

  bool has_match() const { return match_manufacturer || match_product_code || match_name; }
  // True when every given match key equals the profile's (an override without [match]
  // matches everything: use it only when the user named the file).
  bool matches(const Profile& profile) const;
};

// Accepts {"match": {...}, "profile": {...}} or, for requests, the profile keys at the top.
Result<ProfileOverride> parse_profile_override(const nlohmann::json& j, const std::string& source);
Result<ProfileOverride> parse_profile_override_toml(std::string_view text, const std::string& source);
// By extension: .toml or .json.
Result<ProfileOverride> load_profile_override(const std::filesystem::path& path, const io::InputFiles& files = {});
// Every *.toml / *.json in `dir`, in name order; a missing directory is an empty list.
Result<std::vector<ProfileOverride>> load_profile_overrides(const std::filesystem::path& dir);

// Applies the override's values (with a note each) and validates the result.
Result<Profile> apply_override(Profile profile, const ProfileOverride& override_);
// Applies every override in `overrides` that has a [match] and matches, in order.
Result<Profile> apply_matching_overrides(Profile profile, const std::vector<ProfileOverride>& overrides);

// Where hdrd looks for override files: $HDRD_PROFILE_DIR, $XDG_CONFIG_HOME/hdrd/profiles
// (or ~/.config/hdrd/profiles), /etc/hdrd/profiles.
std::vector<std::filesystem::path> default_profile_dirs();

}  // namespace hdrd::display
