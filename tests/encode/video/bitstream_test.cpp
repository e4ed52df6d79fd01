// The metadata hdrd writes into bitstreams (encode/video/bitstream.hpp, hdr10plus.hpp):
// syntax laid out bit by bit here from ISO/IEC 23008-2, the AV1 spec and ST 2094-40, and
// the insertions into access units / temporal units. ffprobe and libavcodec read the
// real thing back in writer_test.cpp.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "encode/video/bitstream.hpp"
#include "encode/video/hdr10plus.hpp"

using namespace hdrd;
using namespace hdrd::video;
using Bytes = std::vector<std::uint8_t>;

namespace {

// "0101..." -> bytes, zero-padded.
Bytes bits(const std::string& s) {
  Bytes out((s.size() + 7) / 8, 0);
  for (std::size_t i = 0; i < s.size(); ++i)
    if (s[i] == '1') out[i / 8] |= static_cast<std::uint8_t>(0x80 >> (i % 8));
  return out;
}
std::string field(std::uint64_t v, int n) {
  std::string s;
  for (int i = n - 1; i >= 0; --i) s += ((v >> i) & 1) ? '1' : '0';
  return s;
}

TEST(BitWriter, PacksMsbFirst) {
  BitWriter w;
  w.put(1, 1);
  w.put(0x5, 3);
  w.put(0x1FF, 9);
  EXPECT_EQ(w.bit_count(), 13u);
  EXPECT_EQ(w.bytes(), bits("1101111111111"));
}

Hdr10PlusFrame sample() {
  Hdr10PlusFrame m;
  m.maxscl = {17830, 16895, 14252};
  m.average_maxrgb = 1037;
  const int values[9] = {0, 1, 4, 30, 238, 1015, 1632, 1995, 3262};
  for (int i = 0; i < 9; ++i) m.distribution.push_back({static_cast<std::uint8_t>(kHdr10PlusPercentages[static_cast<std::size_t>(i)]), static_cast<std::uint32_t>(values[i])});
  return m;
}

TEST(Hdr10Plus, T35LayoutFollowsSt2094_40) {
  Hdr10PlusFrame m = sample();
  std::string s = field(0xB5, 8) + field(0x003C, 16) + field(0x0001, 16) + field(4, 8) + field(1, 8);
  s += field(1, 2) + field(0, 27) + field(0, 1);  // one window, TSDML 0, no actual-peak matrix
  for (auto v : m.maxscl) s += field(v, 17);
  s += field(1037, 17) + field(9, 4);
  for (const auto& p : m.distribution) s += field(p.percentage, 7) + field(p.value, 17);
  s += field(0, 10) + field(0, 1) + field(0, 1) + field(0, 1);  // bright pixels, mastering flag, no curve, no saturation
  EXPECT_EQ(hdr10plus_t35(m), bits(s));
  m.targeted_system_display_maximum_luminance = 400;
  m.bezier = Hdr10PlusBezier{1000, 2500, {102, 205, 307, 410, 512, 614, 717, 819, 922}};
  const Bytes b = hdr10plus_t35(m);
  std::string tail = field(1, 1) + field(1000, 12) + field(2500, 12) + field(9, 4);
  for (auto a : m.bezier->anchors) tail += field(a, 10);
  tail += field(0, 1);
  std::string s2 = s.substr(0, 8 + 16 + 16 + 8 + 8 + 2) + field(400, 27) + s.substr(8 + 16 + 16 + 8 + 8 + 2 + 27);
  s2 = s2.substr(0, s2.size() - 2) + tail;  // replace "no curve, no saturation"
  EXPECT_EQ(b, bits(s2));
}

TEST(Hdr10Plus, ValidationNamesTheField) {
  EXPECT_TRUE(validate(sample()).ok());
  auto with = [](auto f) {
    Hdr10PlusFrame m = sample();
    f(m);
    return validate(m);
  };
  EXPECT_EQ(with([](auto& m) { m.maxscl[1] = 100001; }).error().field, "hdr10plus.maxscl");
  EXPECT_EQ(with([](auto& m) { m.average_maxrgb = 200000; }).error().field, "hdr10plus.average_maxrgb");
  EXPECT_EQ(with([](auto& m) { m.targeted_system_display_maximum_luminance = 10001; }).error().field,
            "hdr10plus.targeted_system_display_maximum_luminance");
  EXPECT_FALSE(with([](auto& m) { m.distribution[3].value = 0; }).ok());       // decreasing
  EXPECT_FALSE(with([](auto& m) { m.distribution[4].percentage = 25; }).ok()); // repeated percentage
  EXPECT_FALSE(with([](auto& m) { m.distribution.clear(); }).ok());
  EXPECT_FALSE(with([](auto& m) { m.fraction_bright_pixels = 1001; }).ok());
  EXPECT_FALSE(with([](auto& m) { m.bezier = Hdr10PlusBezier{10, 10, {1, 2}}; }).ok());  // curve without its display
  EXPECT_FALSE(with([](auto& m) {
                 m.targeted_system_display_maximum_luminance = 500;
                 m.bezier = Hdr10PlusBezier{10, 10, std::vector<std::uint16_t>(10, 5)};
               }).ok());
  EXPECT_FALSE(with([](auto& m) {
                 m.targeted_system_display_maximum_luminance = 500;
                 m.bezier = Hdr10PlusBezier{4096, 10, {}};
               }).ok());
}

TEST(Hdr10Plus, JsonEntryIsX265sLlcLayout) {
  const auto j = hdr10plus_json_entry(sample(), 2, 3, 40);
  EXPECT_EQ(j["LuminanceParameters"]["AverageRGB"], 1037);
  EXPECT_EQ(j["LuminanceParameters"]["MaxScl"], (nlohmann::json{17830, 16895, 14252}));
  EXPECT_EQ(j["LuminanceParameters"]["LuminanceDistributions"]["DistributionIndex"],
            (nlohmann::json{1, 5, 10, 25, 50, 75, 90, 95, 99}));
  EXPECT_EQ(j["LuminanceParameters"]["LuminanceDistributions"]["DistributionValues"][8], 3262);
  EXPECT_EQ(j["NumberOfWindows"], 1);
  EXPECT_EQ(j["TargetedSystemDisplayMaximumLuminance"], 0);
  EXPECT_EQ(j["SceneId"], 2);
  EXPECT_EQ(j["SceneFrameIndex"], 3);
  EXPECT_EQ(j["SequenceFrameIndex"], 40);
  EXPECT_FALSE(j.contains("BezierCurveData"));  // profile A
}

// ---- HEVC SEI --------------------------------------------------------------------------

TEST(HevcSei, MessagesPayloadNumbersAndEmulationPrevention) {
  // A content-light message whose payload 00 00 00 01 needs two emulation prevention bytes.
  const SeiMessage cll{kSeiContentLightLevelInfo, sei_content_light({0, 1})};
  EXPECT_EQ(cll.payload, (Bytes{0, 0, 0, 1}));
  const Bytes nal = hevc_prefix_sei_nal(std::vector<SeiMessage>{cll});
  // start code, header (type 39), type 144, size 4, 00 00 [03] 00 01, trailing bits
  EXPECT_EQ(nal, (Bytes{0, 0, 0, 1, 0x4E, 0x01, 144, 4, 0, 0, 3, 0, 1, 0x80}));
  // payloadType 300 and a 260-byte payload: 0xFF-prefixed numbers (§7.3.5).
  const Bytes big = hevc_prefix_sei_nal(std::vector<SeiMessage>{{300, Bytes(260, 0x11)}});
  EXPECT_EQ((Bytes{big[6], big[7], big[8], big[9]}), (Bytes{0xFF, 45, 0xFF, 5}));
  EXPECT_EQ(big.size(), 4u + 2 + 4 + 260 + 1);
}

TEST(HevcSei, MasteringDisplayIsGreenBlueRedThenWhite) {
  io::St2086Codes c;
  c.red = {34000, 16000}, c.green = {13250, 34500}, c.blue = {7500, 3000}, c.white = {15635, 16450};
  c.max_luminance = 10000000, c.min_luminance = 50;
  const Bytes p = sei_mastering_display(c);
  ASSERT_EQ(p.size(), 24u);
  auto u16 = [&](int i) { return p[static_cast<std::size_t>(i)] << 8 | p[static_cast<std::size_t>(i) + 1]; };
  EXPECT_EQ(u16(0), 13250);  // green x
  EXPECT_EQ(u16(4), 7500);   // blue x
  EXPECT_EQ(u16(8), 34000);  // red x
  EXPECT_EQ(u16(12), 15635);
  EXPECT_EQ((u16(16) << 16) | u16(18), 10000000);
  EXPECT_EQ((u16(20) << 16) | u16(22), 50);
}

Bytes nal(int type, Bytes body) {
  Bytes b{0, 0, 0, 1, static_cast<std::uint8_t>(type << 1), 1};
  b.insert(b.end(), body.begin(), body.end());
  return b;
}
Bytes cat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const auto& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

TEST(HevcSei, InsertedAfterParameterSetsBeforeTheFirstSlice) {
  const Bytes vps = nal(32, {1, 2}), sps = nal(33, {3}), pps = nal(34, {4}), sei = nal(39, {5, 0x80});
  const Bytes idr = nal(19, {0xAA, 0xBB}), slice2 = Bytes{0, 0, 1, 19 << 1, 1, 0xCC};  // a 3-byte start code too
  const Bytes ours = nal(39, {9, 9, 0x80});
  auto out = hevc_insert_before_slices(cat({vps, sps, pps, sei, idr, slice2}), ours);
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(*out, cat({vps, sps, pps, sei, ours, idr, slice2}));
  auto trail = hevc_insert_before_slices(nal(1, {7}), ours);  // a lone TRAIL_R slice
  EXPECT_EQ(*trail, cat({ours, nal(1, {7})}));
  EXPECT_FALSE(hevc_insert_before_slices(Bytes{1, 2, 3, 4}, ours).ok());      // not Annex B
  EXPECT_FALSE(hevc_insert_before_slices(cat({vps, sps}), ours).ok());         // no slice
  EXPECT_FALSE(hevc_insert_before_slices(Bytes{0, 0, 1}, ours).ok());          // truncated
  EXPECT_FALSE(hevc_insert_before_slices(Bytes{}, ours).ok());
}

// ---- AV1 OBUs --------------------------------------------------------------------------

TEST(Av1Metadata, ObuLayout) {
  const Bytes cll = av1_metadata_obu(kAv1MetadataHdrCll, av1_content_light({1000, 400}));
  // obu_header: type 5 (METADATA), has_size_field; size 6; metadata_type 1; 03E8 0190; trailing bits.
  EXPECT_EQ(cll, (Bytes{0x2A, 6, 1, 0x03, 0xE8, 0x01, 0x90, 0x80}));
  MasteringDisplay m;
  m.primaries = color::kRec2020;
  m.max_nits = 1000, m.min_nits = 0.005;
  const Bytes mdcv = av1_mastering_display(m);
  ASSERT_EQ(mdcv.size(), 24u);
  auto u16 = [&](int i) { return mdcv[static_cast<std::size_t>(i)] << 8 | mdcv[static_cast<std::size_t>(i) + 1]; };
  EXPECT_EQ(u16(0), static_cast<int>(std::lround(0.708 * 65536)));  // red x, 0.16 fixed point
  EXPECT_EQ(u16(6), static_cast<int>(std::lround(0.797 * 65536)));  // green y
  EXPECT_EQ((u16(16) << 16) | u16(18), 1000 * 256);                 // 24.8
  EXPECT_EQ((u16(20) << 16) | u16(22), static_cast<int>(std::lround(0.005 * 16384)));  // 18.14
  // A 200-byte payload: two-byte leb128 sizes.
  const Bytes t35 = av1_metadata_obu(kAv1MetadataItutT35, Bytes(200, 7));
  EXPECT_EQ((Bytes{t35[0], t35[1], t35[2], t35[3]}), (Bytes{0x2A, (202 & 0x7F) | 0x80, 1, 4}));
}

Bytes obu(int type, Bytes payload, bool extension = false) {
  Bytes b{static_cast<std::uint8_t>(type << 3 | 0x02 | (extension ? 0x04 : 0))};
  if (extension) b.push_back(0);
  b.push_back(static_cast<std::uint8_t>(payload.size()));
  b.insert(b.end(), payload.begin(), payload.end());
  return b;
}

TEST(Av1Metadata, InsertedAfterTheSequenceHeaderBeforeTheFrame) {
  const Bytes td = obu(2, {}), seq = obu(1, {1, 2, 3}), frame = obu(6, {9, 9, 9, 9}, true), ours = obu(5, {4, 1, 0x80});
  auto out = av1_insert_before_frames(cat({td, seq, frame}), ours);
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(*out, cat({td, seq, ours, frame}));
  const Bytes header = obu(3, {1}), tile = obu(4, {2});
  EXPECT_EQ(*av1_insert_before_frames(cat({header, tile}), ours), cat({ours, header, tile}));
  // Without a size field the OBU runs to the end.
  const Bytes unsized{static_cast<std::uint8_t>(6 << 3), 1, 2, 3};
  EXPECT_EQ(*av1_insert_before_frames(cat({td, unsized}), ours), cat({td, ours, unsized}));
  EXPECT_FALSE(av1_insert_before_frames(cat({td, seq}), ours).ok());                  // no frame
  EXPECT_FALSE(av1_insert_before_frames(Bytes{0x0A, 50, 1}, ours).ok());              // size past the end
  EXPECT_FALSE(av1_insert_before_frames(Bytes{0x8A, 0}, ours).ok());                  // forbidden bit
  EXPECT_FALSE(av1_insert_before_frames(Bytes{0x0A, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF}, ours).ok());
}

}  // namespace
