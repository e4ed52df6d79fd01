// Human-readable EDID output in edid-decode's layout (edid-decode -s -c, Debian 12).
// Only lines whose exact wording we know are printed, so the text is a line-by-line
// subsequence of edid-decode's own output for the same blob; the tests check that on
// every fixture (the libdisplay-info approach: diff against edid-decode).
#include <string>

#include <fmt/format.h>

#include "display/edid.hpp"
#include "display/edid_detail.hpp"

namespace hdrd::display {
namespace {

class Out {
 public:
  template <class... Args>
  void line(int indent, fmt::format_string<Args...> f, Args&&... args) {
    text_.append(static_cast<std::size_t>(indent) * 2, ' ');
    text_ += fmt::format(f, std::forward<Args>(args)...);
    text_ += '\n';
  }
  std::string take() { return std::move(text_); }

 private:
  std::string text_;
};

// edid-decode prints 0.%04u of raw * 10000 / 1024 with integer division: truncated.
std::string chroma(std::uint16_t raw) { return fmt::format("0.{:04}", raw * 10000u / 1024u); }

void base_identification(const EdidInfo& e, Out& o) {
  o.line(1, "Vendor & Product Identification:");
  o.line(2, "Manufacturer: {}", e.manufacturer);
  o.line(2, "Model: {}", e.product_code);
  if (e.serial_number) o.line(2, "Serial Number: {}", e.serial_number);
  if (e.model_year) o.line(2, "Model year: {}", e.manufacture_year);
  else if (e.manufacture_week) o.line(2, "Made in: week {} of {}", e.manufacture_week, e.manufacture_year);
  else o.line(2, "Made in: {}", e.manufacture_year);
}

void base_parameters(const EdidInfo& e, Out& o) {
  o.line(1, "Basic Display Parameters & Features:");
  o.line(2, "{} display", e.digital ? "Digital" : "Analog");
  if (e.bits_per_color) o.line(2, "Bits per primary color channel: {}", e.bits_per_color);
  if (!e.interface.empty()) o.line(2, "{} interface", e.interface);
  if (e.width_cm && e.height_cm) o.line(2, "Maximum image size: {} cm x {} cm", e.width_cm, e.height_cm);
  if (e.gamma) o.line(2, "Gamma: {:.2f}", *e.gamma);
  o.line(1, "Color Characteristics:");
  const auto& c = e.chromaticity;
  o.line(2, "Red  : {}, {}", chroma(c.red.x), chroma(c.red.y));
  o.line(2, "Green: {}, {}", chroma(c.green.x), chroma(c.green.y));
  o.line(2, "Blue : {}, {}", chroma(c.blue.x), chroma(c.blue.y));
  o.line(2, "White: {}, {}", chroma(c.white.x), chroma(c.white.y));
}

void base_block(const EdidInfo& e, Out& o) {
  o.line(0, "Block 0, Base EDID:");
  o.line(1, "EDID Structure Version & Revision: {}.{}", e.version, e.revision);
  base_identification(e, o);
  base_parameters(e, o);
  o.line(1, "Detailed Timing Descriptors:");
  for (const auto& d : e.text_descriptors) {
    if (!d.printable) continue;
    const char* what = d.tag == 0xfc ? "Display Product Name"
                       : d.tag == 0xff ? "Display Product Serial Number" : "Alphanumeric Data String";
    o.line(2, "{}: '{}'", what, d.text);
  }
  if (e.extension_count) o.line(1, "Extension blocks: {}", e.extension_count);
  o.line(0, "Checksum: 0x{:02x}", e.base_checksum);
}

void hdr_static(const HdrStaticMetadata& h, Out& o) {
  o.line(2, "Electro optical transfer functions:");
  static constexpr const char* kEotf[4] = {"Traditional gamma - SDR luminance range",
                                           "Traditional gamma - HDR luminance range", "SMPTE ST2084",
                                           "Hybrid Log-Gamma"};
  for (int i = 0; i < 4; ++i)
    if (h.eotf_bits & (1 << i)) o.line(3, "{}", kEotf[i]);
  o.line(2, "Supported static metadata descriptors:");
  if (h.static_metadata_type1()) o.line(3, "Static metadata type 1");
  if (h.max_luminance_cv)
    o.line(2, "Desired content max luminance: {} ({:.3f} cd/m^2)", *h.max_luminance_cv, *h.max_luminance_cd_m2());
  if (h.max_frame_avg_luminance_cv)
    o.line(2, "Desired content max frame-average luminance: {} ({:.3f} cd/m^2)", *h.max_frame_avg_luminance_cv,
           *h.max_frame_avg_luminance_cd_m2());
  if (h.min_luminance_cv)
    o.line(2, "Desired content min luminance: {} ({:.3f} cd/m^2)", *h.min_luminance_cv, *h.min_luminance_cd_m2());
}

void video_capability(const VideoCapability& v, Out& o) {
  static constexpr const char* kScan[4] = {"No Data", "Always Overscanned", "Always Underscanned",
                                           "Supports both over- and underscan"};
  o.line(2, "YCbCr quantization: {}", v.ycc_quantization_selectable ? "Selectable (via AVI YQ)" : "No Data");
  o.line(2, "RGB quantization: {}", v.rgb_quantization_selectable ? "Selectable (via AVI Q)" : "No Data");
  o.line(2, "PT scan behavior: {}", kScan[v.pt & 3]);
  // IT/CE value 0 means "not supported", worded differently: leave it out.
  if (v.it) o.line(2, "IT scan behavior: {}", kScan[v.it & 3]);
  if (v.ce) o.line(2, "CE scan behavior: {}", kScan[v.ce & 3]);
}

void cta_blocks(const std::vector<CtaDataBlock>& blocks, Out& o) {
  for (const auto& db : blocks) {
    if (!db.name_matches_edid_decode) continue;
    o.line(1, "{}:", db.name);
    if (db.colorimetry)
      for (const auto& n : db.colorimetry->names()) o.line(2, "{}", n);
    if (db.hdr_static) hdr_static(*db.hdr_static, o);
    if (db.video_capability) video_capability(*db.video_capability, o);
  }
}

void cta_block(const CtaExtension& c, const ExtensionBlock& ext, Out& o) {
  o.line(0, "Block {}, {}:", ext.index, ext.name);
  o.line(1, "Revision: {}", c.revision);
  if (c.revision >= 2) {
    if (c.flags & 0x80) o.line(1, "Underscans IT Video Formats by default");
    if (c.flags & 0x40) o.line(1, "Basic audio support");
    if (c.flags & 0x20) o.line(1, "Supports YCbCr 4:4:4");
    if (c.flags & 0x10) o.line(1, "Supports YCbCr 4:2:2");
    o.line(1, "Native detailed modes: {}", c.flags & 0x0f);
  }
  cta_blocks(c.data_blocks, o);
  o.line(0, "Checksum: 0x{:02x}", ext.checksum);
}

void display_parameters(const DisplayIdDisplayParameters& d, Out& o) {
  if (d.size_in_mm) o.line(2, "Image size: {} mm x {} mm", d.width_raw, d.height_raw);
  else o.line(2, "Image size: {:.1f} mm x {:.1f} mm", d.width_raw / 10.0, d.height_raw / 10.0);
  if (d.h_pixels && d.v_pixels) o.line(2, "Display native pixel format: {}x{}", d.h_pixels, d.v_pixels);
  if ((d.features & 7) == 0) o.line(2, "Scan Orientation: Left to Right, Top to Bottom");
  if (d.luminance_info() < 2)
    o.line(2, "Luminance Information: {}",
           d.luminance_info() == 0 ? "Minimum guaranteed value" : "Guidance for the Source device");
  o.line(2, "Color Information: CIE {}", d.cie1976() ? 1976 : 1931);
  o.line(2, "Audio Speaker Information: {}integrated", (d.features & 0x80) ? "not " : "");
  o.line(2, "Native Color Chromaticity:");
  static constexpr const char* kLabel[4] = {"Primary #1:  ", "Primary #2:  ", "Primary #3:  ", "White Point: "};
  for (int i = 0; i < 4; ++i)
    o.line(3, "{}({:.6f}, {:.6f})", kLabel[i], d.raw_primaries[i][0] / 4096.0, d.raw_primaries[i][1] / 4096.0);
  o.line(2, "Native Maximum Luminance (Full Coverage): {:.6f} cd/m^2", d.max_full_cd_m2());
  o.line(2, "Native Maximum Luminance (10% Rectangular Coverage): {:.6f} cd/m^2", d.max_10pct_cd_m2());
  o.line(2, "Native Minimum Luminance: {:.6f} cd/m^2", d.min_cd_m2());
  if (auto bpc = d.color_depth_bpc()) o.line(2, "Native Color Depth: {} bpc", *bpc);
  if (d.device_technology() == 1) o.line(2, "Display Device Technology: Active Matrix LCD");
  if (d.device_technology() == 2) o.line(2, "Display Device Technology: Organic LED");
  if (d.gamma) o.line(2, "Native Gamma EOTF: {:.2f}", *d.gamma);
}

std::string bpc_list(std::uint8_t bits, int first_bpc) {
  std::string s;
  for (int i = 0; i < 6; ++i)
    if (bits & (1 << i)) s += fmt::format("{}{}", s.empty() ? "" : ", ", first_bpc + 2 * i);
  return s;
}

void interface_features(const DisplayIdInterfaceFeatures& f, Out& o) {
  static constexpr const char* kEncoding[4] = {"RGB", "YCbCr 4:4:4", "YCbCr 4:2:2", "YCbCr 4:2:0"};
  for (int i = 0; i < 4; ++i)
    if (f.bpc_bits[i]) o.line(2, "Supported bpc for {} encoding: {}", kEncoding[i], bpc_list(f.bpc_bits[i], i < 2 ? 6 : 8));
  const auto names = f.combination_names();
  if (!names.empty())
    o.line(2, "Supported color space and EOTF standard combination 1: {}", fmt::join(names, ", "));
}

void displayid_block(const DisplayIdSection& s, bool first, const ExtensionBlock& ext, Out& o) {
  o.line(0, "Block {}, {}:", ext.index, ext.name);
  o.line(1, "Version: {}", s.version_string());
  o.line(1, "Extension Count: {}", s.extension_count);
  // Only the first section states the product type; later ones continue it.
  if (first && s.is_v2() && s.product_type == 2)
    o.line(1, "Display Product Primary Use Case: None of the listed primary use cases; generic display");
  if (first && !s.is_v2() && s.product_type == 0) o.line(1, "Display Product Type: Extension Section");
  for (const auto& db : s.data_blocks) {
    if (db.tag == 0x20 && s.is_v2() && db.oui) {
      o.line(1, "{}, OUI {}:", db.name, detail::oui_string(*db.oui));
    } else if (db.name_matches_edid_decode) {
      o.line(1, "{}:", db.name);
    }
    if (db.parameters) display_parameters(*db.parameters, o);
    if (db.interface) interface_features(*db.interface, o);
    cta_blocks(db.cta, o);
  }
  o.line(1, "Checksum: 0x{:02x}", s.checksum);
  o.line(0, "Checksum: 0x{:02x}", ext.checksum);
}

}  // namespace

std::string format_edid_text(const EdidInfo& info) {
  Out o;
  base_block(info, o);
  std::size_t cta = 0, did = 0;
  for (const auto& ext : info.extensions) {
    if (ext.tag == 0x02 && cta < info.cta.size()) {
      cta_block(info.cta[cta++], ext, o);
    } else if (ext.tag == 0x70 && did < info.displayid.size()) {
      displayid_block(info.displayid[did], did == 0, ext, o);
      ++did;
    } else {
      o.line(0, "Block {}, {}:", ext.index, ext.name);
      o.line(0, "Checksum: 0x{:02x}", ext.checksum);
    }
  }
  return o.take();
}

}  // namespace hdrd::display
