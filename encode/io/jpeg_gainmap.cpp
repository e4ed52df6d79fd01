// The gain-map JPEG: the SDR rendition as the primary JPEG, followed by the gain map as a
// second JPEG, tied together and described twice, for the two kinds of reader in use:
//  - ISO 21496-1: an APP2 "urn:iso:std:iso:ts:21496:-1" segment in the primary with the
//    version only, and in the gain map image with the whole metadata (binary, big-endian);
//  - Ultra HDR 1.0 (Android, Chrome): XMP "hdrgm" in both images, a GContainer directory in the
//    primary's XMP, and a CIPA DC-007 Multi-Picture Format (MPF) index in the primary.
// Segment order of the primary: SOI, APP0 JFIF, APP1 XMP, APP2 ISO, APP2 MPF, the image.
// Of the gain map: SOI, APP0 JFIF, APP1 XMP, APP2 ISO, the image.
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "encode/io/internal.hpp"
#include "encode/io/io.hpp"
#include "encode/io/stills.hpp"

namespace hdrd::io {
namespace {

using Bytes = std::vector<std::uint8_t>;

constexpr char kXmpNamespace[] = "http://ns.adobe.com/xap/1.0/";  // + NUL (XMP part 3 §1.1.3)
constexpr char kIsoNamespace[] = "urn:iso:std:iso:ts:21496:-1";   // + NUL

void put(Bytes& b, std::uint64_t v, int n) {
  for (int s = 8 * (n - 1); s >= 0; s -= 8) b.push_back(static_cast<std::uint8_t>(v >> s));
}
Bytes with_namespace(const char* ns, const Bytes& body) {
  Bytes b(ns, ns + std::char_traits<char>::length(ns) + 1);  // the NUL too
  b.insert(b.end(), body.begin(), body.end());
  return b;
}
Bytes bytes_of(const std::string& s) { return Bytes(s.begin(), s.end()); }

// ---- ISO 21496-1 metadata (clause 6: min version, writer version, flags, fractions) ----------
// Every value as a fraction over 10^6 (the values were rounded to that in compute_gain_map);
// no common denominator, so a reader needs only the two flag bits that every version defines.
constexpr std::uint32_t kDenominator = 1000000;

void put_signed(Bytes& b, double v) {
  put(b, static_cast<std::uint32_t>(static_cast<std::int32_t>(std::lround(v * kDenominator))), 4);
  put(b, kDenominator, 4);
}
void put_unsigned(Bytes& b, double v) {
  put(b, static_cast<std::uint32_t>(std::lround(v * kDenominator)), 4);
  put(b, kDenominator, 4);
}

Bytes iso_version() {
  Bytes b;
  put(b, 0, 2);  // minimum_version
  put(b, 0, 2);  // writer_version
  return b;
}

Bytes iso_metadata(const GainMapMetadata& m) {
  Bytes b = iso_version();
  const std::uint8_t is_multichannel = m.channels == 3 ? 0x80 : 0;
  const std::uint8_t use_base_colour_space = 0x40;  // the maths runs in the base's Rec.709
  b.push_back(is_multichannel | use_base_colour_space);
  put_unsigned(b, m.hdr_capacity_min_log2);  // base_hdr_headroom
  put_unsigned(b, m.hdr_capacity_max_log2);  // alternate_hdr_headroom
  for (int c = 0; c < m.channels; ++c) {
    put_signed(b, m.gain_map_min_log2[static_cast<std::size_t>(c)]);
    put_signed(b, m.gain_map_max_log2[static_cast<std::size_t>(c)]);
    put_unsigned(b, m.gamma);
    put_signed(b, m.offset_sdr);  // base_offset
    put_signed(b, m.offset_hdr);  // alternate_offset
  }
  return b;
}

// ---- Ultra HDR XMP -------------------------------------------------------------------------
std::string number(double v) { return fmt::format("{:.6f}", v); }

constexpr char kXmpOpen[] =
    "<x:xmpmeta xmlns:x=\"adobe:ns:meta/\" x:xmptk=\"hdrd\">\n"
    "  <rdf:RDF xmlns:rdf=\"http://www.w3.org/1999/02/22-rdf-syntax-ns#\">\n";
constexpr char kXmpClose[] = "  </rdf:RDF>\n</x:xmpmeta>\n";

// hdrgm:GainMapMin/Max: an attribute for a one-channel map, an rdf:Seq of R, G, B otherwise
// (Adobe gain map specification 1.0 §2.3).
void add_per_channel(std::string& attributes, std::string& elements, const char* name,
                     const std::array<double, 3>& v, int channels) {
  if (channels == 1) {
    attributes += fmt::format("\n      hdrgm:{}=\"{}\"", name, number(v[0]));
    return;
  }
  elements += fmt::format("      <hdrgm:{0}><rdf:Seq><rdf:li>{1}</rdf:li><rdf:li>{2}</rdf:li><rdf:li>{3}</rdf:li>"
                          "</rdf:Seq></hdrgm:{0}>\n",
                          name, number(v[0]), number(v[1]), number(v[2]));
}

std::string gain_map_xmp(const GainMapMetadata& m) {
  std::string attributes = fmt::format(
      "\n      hdrgm:Version=\"1.0\" hdrgm:Gamma=\"{}\" hdrgm:OffsetSDR=\"{}\" hdrgm:OffsetHDR=\"{}\""
      "\n      hdrgm:HDRCapacityMin=\"{}\" hdrgm:HDRCapacityMax=\"{}\" hdrgm:BaseRenditionIsHDR=\"False\"",
      number(m.gamma), number(m.offset_sdr), number(m.offset_hdr), number(m.hdr_capacity_min_log2),
      number(m.hdr_capacity_max_log2));
  std::string elements;
  add_per_channel(attributes, elements, "GainMapMin", m.gain_map_min_log2, m.channels);
  add_per_channel(attributes, elements, "GainMapMax", m.gain_map_max_log2, m.channels);
  const std::string open = fmt::format(
      "    <rdf:Description rdf:about=\"\" xmlns:hdrgm=\"http://ns.adobe.com/hdr-gain-map/1.0/\"{}", attributes);
  const std::string body = elements.empty() ? open + "/>\n" : open + ">\n" + elements + "    </rdf:Description>\n";
  return kXmpOpen + body + kXmpClose;
}

std::string primary_xmp(std::size_t gain_map_bytes) {
  return fmt::format(
      "{}    <rdf:Description rdf:about=\"\" xmlns:hdrgm=\"http://ns.adobe.com/hdr-gain-map/1.0/\"\n"
      "      xmlns:Container=\"http://ns.google.com/photos/1.0/container/\"\n"
      "      xmlns:Item=\"http://ns.google.com/photos/1.0/container/item/\"\n"
      "      hdrgm:Version=\"1.0\">\n"
      "      <Container:Directory>\n        <rdf:Seq>\n"
      "          <rdf:li rdf:parseType=\"Resource\">\n"
      "            <Container:Item Item:Semantic=\"Primary\" Item:Mime=\"image/jpeg\"/>\n          </rdf:li>\n"
      "          <rdf:li rdf:parseType=\"Resource\">\n"
      "            <Container:Item Item:Semantic=\"GainMap\" Item:Mime=\"image/jpeg\" Item:Length=\"{}\"/>\n"
      "          </rdf:li>\n        </rdf:Seq>\n      </Container:Directory>\n    </rdf:Description>\n{}",
      kXmpOpen, gain_map_bytes, kXmpClose);
}

// ---- MPF (CIPA DC-007-2009 §5.2): big-endian TIFF-style index IFD with 3 tags ----------------
constexpr std::size_t kMpfPayload = 4 + 8 + 2 + 3 * 12 + 4 + 2 * 16;  // "MPF\0", header, IFD, 2 entries

Bytes mpf(std::uint32_t primary_bytes, std::uint32_t gain_map_bytes, std::uint32_t gain_map_offset) {
  Bytes b{'M', 'P', 'F', 0, 'M', 'M', 0, 0x2A};
  put(b, 8, 4);  // first IFD right after the 8-byte header
  put(b, 3, 2);
  const auto tag = [&](std::uint16_t id, std::uint16_t type, std::uint32_t count, std::uint32_t value) {
    put(b, id, 2), put(b, type, 2), put(b, count, 4), put(b, value, 4);
  };
  tag(0xB000, 7, 4, 0x30313030);   // MPFVersion "0100", UNDEFINED
  tag(0xB001, 4, 1, 2);            // NumberOfImages, LONG
  tag(0xB002, 7, 32, 8 + 2 + 36 + 4);  // MPEntry: 2 x 16 bytes after this IFD
  put(b, 0, 4);                    // no next IFD
  // MP entries: attribute (0x030000 = baseline MP primary image; 0 = the gain map, as
  // libultrahdr writes it), size, offset from the TIFF header (0 for the first image), 2 x dependent.
  put(b, 0x030000, 4), put(b, primary_bytes, 4), put(b, 0, 4), put(b, 0, 4);
  put(b, 0, 4), put(b, gain_map_bytes, 4), put(b, gain_map_offset, 4), put(b, 0, 4);
  return b;
}

Bytes segment(std::uint8_t marker, const Bytes& payload) {
  Bytes s{0xFF, marker};
  put(s, payload.size() + 2, 2);
  s.insert(s.end(), payload.begin(), payload.end());
  return s;
}

// Where the segments go: after SOI and the APP0 JFIF that libjpeg writes first.
std::size_t after_jfif(const Bytes& jpeg) {
  if (jpeg.size() > 6 && jpeg[2] == 0xFF && jpeg[3] == 0xE0) return 4 + ((std::size_t{jpeg[4]} << 8) | jpeg[5]);
  return 2;
}

Result<Bytes> assemble(const Bytes& primary, const Bytes& gain_map) {
  const std::size_t at = after_jfif(primary);
  Bytes head = segment(0xE1, with_namespace(kXmpNamespace, bytes_of(primary_xmp(gain_map.size()))));
  const Bytes iso = segment(0xE2, with_namespace(kIsoNamespace, iso_version()));
  head.insert(head.end(), iso.begin(), iso.end());
  const std::size_t tiff_header = at + head.size() + 4 + 4;  // marker, length, "MPF\0"
  const std::size_t primary_bytes = primary.size() + head.size() + 4 + kMpfPayload;
  if (primary_bytes + gain_map.size() > 0xffffffffu) return make_error("jpeg.size", "gain-map JPEG exceeds 4 GiB");
  const Bytes index = segment(0xE2, mpf(static_cast<std::uint32_t>(primary_bytes),
                                        static_cast<std::uint32_t>(gain_map.size()),
                                        static_cast<std::uint32_t>(primary_bytes - tiff_header)));
  head.insert(head.end(), index.begin(), index.end());
  Bytes out(primary.begin(), primary.begin() + static_cast<long>(at));
  out.insert(out.end(), head.begin(), head.end());
  out.insert(out.end(), primary.begin() + static_cast<long>(at), primary.end());
  out.insert(out.end(), gain_map.begin(), gain_map.end());
  return out;
}

}  // namespace

Result<GainMapJpeg> encode_jpeg_gainmap(const EncodedFrame& sdr, const EncodedFrame& hdr,
                                        const GainMapOptions& options) {
  auto sdr_rgb = detail::sdr_samples(sdr);
  if (!sdr_rgb) return sdr_rgb.error();
  auto map = detail::gain_map_of(sdr, *sdr_rgb, hdr, options);
  if (!map) return map.error();
  auto primary = detail::compress_jpeg({sdr.width, sdr.height, 3, *sdr_rgb}, options.primary.quality,
                                       options.primary.subsample_chroma);
  if (!primary) return primary.error();
  const std::vector<detail::JpegMarker> markers{
      {0xE1, with_namespace(kXmpNamespace, bytes_of(gain_map_xmp(map->metadata)))},
      {0xE2, with_namespace(kIsoNamespace, iso_metadata(map->metadata))}};
  auto gain = detail::compress_jpeg({map->width, map->height, map->channels, map->samples}, options.gain_map_quality,
                                    false, markers);
  if (!gain) return gain.error();
  auto bytes = assemble(*primary, *gain);
  if (!bytes) return bytes.error();
  GainMapJpeg out;
  out.primary_bytes = bytes->size() - gain->size();
  out.bytes = std::move(*bytes);
  out.map = std::move(*map);
  return out;
}

Result<void> write_jpeg_gainmap(const std::filesystem::path& path, const EncodedFrame& sdr, const EncodedFrame& hdr,
                                const GainMapOptions& options) {
  auto jpeg = encode_jpeg_gainmap(sdr, hdr, options);
  if (!jpeg) return jpeg.error();
  return atomic_write(path, jpeg->bytes);
}

}  // namespace hdrd::io
