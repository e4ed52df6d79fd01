// The KMS output path against a fake device: property ids looked up by name, TEST_ONLY
// before the real commit with the same request, errors propagated, the signalling
// (HDR_OUTPUT_METADATA bytes, Colorspace BT2020_RGB, max bpc) and the scan-out buffer.
#include <gtest/gtest.h>

#include <cstring>

#include "display/kms_output.hpp"
#include "display/scanout.hpp"
#include "encode/colour/transfer.hpp"
#include "tests/display/fake_kms.hpp"

namespace hdrd::display {
namespace {

using namespace hdrd::display::testing;

std::uint32_t xbgr(int r, int g, int b) { return std::uint32_t(r) | (std::uint32_t(g) << 10) | (std::uint32_t(b) << 20); }

std::uint32_t word_at(const std::vector<std::uint8_t>& d, std::size_t off) {
  std::uint32_t v;
  std::memcpy(&v, d.data() + off, 4);
  return v;
}

EncodedFrame hdr10_frame(int w, int h) {
  EncodedFrame f;
  f.target = default_target(Mode::hdr10);
  f.width = w;
  f.height = h;
  f.drm_fourcc = kDrmFormatXbgr2101010;
  f.stride_bytes = static_cast<std::size_t>(w) * 4 + 16;  // a padded stride, as GPUs produce
  f.data.assign(f.stride_bytes * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const std::uint32_t v = xbgr((x * 7) % 1024, (y * 13) % 1024, (x + y) % 1024);
      std::memcpy(f.data.data() + y * f.stride_bytes + 4 * x, &v, 4);
    }
  f.mastering = MasteringDisplay{color::kDisplayP3, 1000.0, 0.005};
  f.content_light = {1000.4, 400.0};
  return f;
}

EncodedFrame sdr_frame(int w, int h) {
  EncodedFrame f;
  f.target = default_target(Mode::sdr);
  f.width = w;
  f.height = h;
  f.drm_fourcc = kDrmFormatXrgb8888;
  f.stride_bytes = static_cast<std::size_t>(w) * 4;
  f.data.assign(f.stride_bytes * h, 0x80);
  return f;
}

// scRGB pixels given as binary16 bit patterns (R, G, B), alpha 1.0.
EncodedFrame scrgb_frame(const std::vector<std::array<std::uint16_t, 3>>& px) {
  EncodedFrame f;
  f.target = default_target(Mode::scrgb);
  f.width = static_cast<int>(px.size());
  f.height = 1;
  f.drm_fourcc = kDrmFormatAbgr16161616f;
  f.stride_bytes = px.size() * 8;
  f.data.assign(f.stride_bytes, 0);
  for (std::size_t i = 0; i < px.size(); ++i) {
    const std::uint16_t v[4] = {px[i][0], px[i][1], px[i][2], 0x3c00};
    std::memcpy(f.data.data() + 8 * i, v, 8);
  }
  f.mastering = MasteringDisplay{color::kRec709, 1000.0, 0.0};
  return f;
}

TEST(AtomicRequest, StickyFailureNamesTheFirstMissingProperty) {
  Properties props(2);
  props[0].id = 7;
  props[0].name = "FB_ID";
  props[0].kind = PropertyKind::object;
  props[1].id = 8;
  props[1].name = "Colorspace";
  props[1].kind = PropertyKind::enumeration;
  props[1].enums = {{"Default", 0}, {"BT2020_RGB", 9}};
  AtomicRequest r;
  r.add(1, props, "FB_ID", 5);
  EXPECT_FALSE(r.failed());
  r.add(1, props, "SRC_W", 10);
  r.add(1, props, "NOPE", 1);
  r.add_enum(1, props, "Colorspace", "BT2020_RGB");  // ignored after the failure
  ASSERT_TRUE(r.failed());
  EXPECT_EQ(r.error(), "object 1 has no \"SRC_W\" property");
  EXPECT_EQ(r.items().size(), 1u);
  EXPECT_EQ(r.items()[0].property, 7u);  // the id found by name

  AtomicRequest e;
  e.add_enum(1, props, "Colorspace", "BT2020_YCC");
  EXPECT_EQ(e.error(), "\"Colorspace\" of object 1 has no entry \"BT2020_YCC\" (it has: Default, BT2020_RGB)");
  AtomicRequest o;
  EXPECT_FALSE(o.add_if_present(1, props, "max bpc", 10));
  EXPECT_FALSE(o.failed());
}

TEST(KmsOutput, Hdr10TestOnlyThenCommitWithSignalling) {
  FakeKmsDevice dev;
  KmsOutput out(dev);
  const EncodedFrame f = hdr10_frame(1920, 1080);
  auto r = out.show(f);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_EQ(dev.commits.size(), 2u);
  EXPECT_EQ(dev.commits[0].flags, kAtomicTestOnly | kAtomicAllowModeset);
  EXPECT_EQ(dev.commits[1].flags, kAtomicAllowModeset);
  ASSERT_EQ(dev.commits[0].items.size(), dev.commits[1].items.size());
  for (std::size_t i = 0; i < dev.commits[0].items.size(); ++i) {
    EXPECT_EQ(dev.commits[0].items[i].property, dev.commits[1].items[i].property);
    EXPECT_EQ(dev.commits[0].items[i].value, dev.commits[1].items[i].value);
  }
  EXPECT_TRUE(r->committed);
  EXPECT_EQ(r->connector, "HDMI-A-1");
  EXPECT_EQ(r->mode.hdisplay, 1920);  // the mode of the frame's size, not the 4K preferred one
  EXPECT_EQ(r->colorspace, "BT2020_RGB");
  // The committed state, read back by property name.
  const auto H = FakeKmsDevice::kHdmi;
  EXPECT_EQ(dev.state(H, "Colorspace"), DRM_MODE_COLORIMETRY_BT2020_RGB);
  EXPECT_EQ(dev.state(H, "max bpc"), 10u);
  EXPECT_EQ(dev.state(H, "CRTC_ID"), FakeKmsDevice::kCrtc);
  EXPECT_EQ(dev.state(FakeKmsDevice::kCrtc, "ACTIVE"), 1u);
  EXPECT_EQ(dev.state(FakeKmsDevice::kPrimary, "SRC_W"), 1920ull << 16);
  EXPECT_EQ(dev.state(FakeKmsDevice::kPrimary, "CRTC_H"), 1080u);
  // HDR_OUTPUT_METADATA blob: the hand-checked bytes of hdr_metadata_test (P3, 1000/0.005, 1000/400).
  const auto& blob = dev.blobs.at(static_cast<std::uint32_t>(dev.state(H, "HDR_OUTPUT_METADATA")));
  ASSERT_EQ(blob.size(), 32u);
  EXPECT_EQ(blob[4], 2);                           // ST 2084
  EXPECT_EQ(blob[6] | (blob[7] << 8), 34000);      // red x 0.680
  EXPECT_EQ(blob[22] | (blob[23] << 8), 1000);     // max mastering
  EXPECT_EQ(blob[24] | (blob[25] << 8), 50);       // min mastering 0.005
  EXPECT_EQ(blob[26] | (blob[27] << 8), 1000);     // MaxCLL 1000.4: at most the mastering maximum
  EXPECT_EQ(blob[28] | (blob[29] << 8), 400);      // MaxFALL
  // The framebuffer holds the frame, row by row despite different strides.
  const auto& fb = dev.framebuffers.at(static_cast<std::uint32_t>(dev.state(FakeKmsDevice::kPrimary, "FB_ID")));
  EXPECT_EQ(fb.fourcc, kDrmFormatXbgr2101010);
  const auto& mem = dev.dumb_memory.at(fb.handle);
  for (int y : {0, 1, 539, 1079})
    for (int x : {0, 5, 1919})
      EXPECT_EQ(word_at(mem, y * fb.pitch + 4 * x), word_at(f.data, y * f.stride_bytes + 4 * x)) << x << "," << y;
}

TEST(KmsOutput, TestOnlyRejectionIsPropagatedAndNothingIsCommitted) {
  FakeKmsDevice dev;
  dev.reject_test_only_errno = EINVAL;
  KmsOutput out(dev);
  auto r = out.show(hdr10_frame(64, 32));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "kms.atomic");
  EXPECT_EQ(r.error().message, "/dev/dri/fake0 rejected the configuration in a TEST_ONLY commit: Invalid argument");
  EXPECT_EQ(dev.commits.size(), 1u);  // no real commit after a failed test
  EXPECT_EQ(dev.state(FakeKmsDevice::kCrtc, "ACTIVE"), 0u);
}

TEST(KmsOutput, CommitFailureAfterAPassingTestIsPropagated) {
  FakeKmsDevice dev;
  dev.reject_commit_errno = EACCES;  // e.g. not DRM master while a compositor runs
  KmsOutput out(dev);
  auto r = out.show(hdr10_frame(64, 32));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "atomic commit on /dev/dri/fake0 failed: Permission denied");
  EXPECT_EQ(dev.commits.size(), 2u);
}

TEST(KmsOutput, TestOnlyOptionStopsBeforeCommitting) {
  FakeKmsDevice dev;
  KmsOutput out(dev);
  PresentOptions o;
  o.test_only = true;
  auto r = out.show(hdr10_frame(64, 32), o);
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r->committed);
  ASSERT_EQ(dev.commits.size(), 1u);
  EXPECT_TRUE(dev.commits[0].flags & kAtomicTestOnly);
}

TEST(KmsOutput, NoConnectedDisplayIsAClearError) {
  FakeKmsDevice dev(true, /*hdmi_connected=*/false);
  KmsOutput out(dev);
  auto r = out.show(hdr10_frame(64, 32));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "kms.no_display");
  EXPECT_EQ(r.error().message,
            "no display attached: no connected connector on /dev/dri/fake0 (HDMI-A-1 disconnected, DP-1 disconnected)");
  PresentOptions o;
  o.connector = "HDMI-A-7";
  auto named = KmsOutput(dev).show(hdr10_frame(64, 32), o);
  EXPECT_EQ(named.error().message, "/dev/dri/fake0 has no connector HDMI-A-7 (it has: HDMI-A-1, DP-1)");
  EXPECT_TRUE(dev.commits.empty());
}

TEST(KmsOutput, HdrNeedsHdrPropertiesUnlessToldOtherwise) {
  FakeKmsDevice dev(/*hdr_properties=*/false);
  auto r = KmsOutput(dev).show(hdr10_frame(64, 32));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "kms.no_hdr");
  EXPECT_NE(r.error().message.find("has no HDR_OUTPUT_METADATA property"), std::string::npos);
  PresentOptions o;
  o.require_hdr_properties = false;
  KmsOutput out(dev);
  auto ok = out.show(hdr10_frame(64, 32), o);
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_FALSE(ok->hdr_metadata);
  EXPECT_FALSE(ok->notes.empty());
}

TEST(KmsOutput, HdrFramesGoToTheFirstConnectorThatCanSignalHdr) {
  FakeKmsDevice dev(/*hdr_properties=*/false);  // HDMI-A-1: connected, no HDR properties
  dev.connect_dp_with_hdr();                    // DP-1: connected, HDR properties
  auto hdr = KmsOutput(dev).show(hdr10_frame(64, 32));
  ASSERT_TRUE(hdr.ok()) << hdr.error().message;
  EXPECT_EQ(hdr->connector, "DP-1");
  auto sdr = KmsOutput(dev).show(sdr_frame(64, 32));
  ASSERT_TRUE(sdr.ok());
  EXPECT_EQ(sdr->connector, "HDMI-A-1");
  PresentOptions named;
  named.connector = "HDMI-A-1";  // a named connector is used as asked, and refused for HDR
  EXPECT_EQ(KmsOutput(dev).show(hdr10_frame(64, 32), named).error().code, "kms.no_hdr");
}

TEST(KmsOutput, SdrClearsHdrStateAndUsesDefaultColorspace) {
  FakeKmsDevice dev;
  KmsOutput out(dev);
  ASSERT_TRUE(out.show(hdr10_frame(64, 32)).ok());
  auto r = out.show(sdr_frame(64, 32));
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(dev.state(FakeKmsDevice::kHdmi, "HDR_OUTPUT_METADATA"), 0u);
  EXPECT_EQ(dev.state(FakeKmsDevice::kHdmi, "Colorspace"), DRM_MODE_COLORIMETRY_DEFAULT);
  EXPECT_FALSE(r->max_bpc);
  EXPECT_EQ(dev.live_dumbs, 1);  // the HDR frame's buffer was released
}

TEST(KmsOutput, SmallerFrameIsPaddedInThePreferredMode) {
  FakeKmsDevice dev;
  KmsOutput out(dev);
  auto r = out.show(hdr10_frame(100, 50));
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->mode.hdisplay, 3840);
  const auto& fb = dev.framebuffers.at(r->fb_id);
  const auto& mem = dev.dumb_memory.at(fb.handle);
  EXPECT_EQ(word_at(mem, 4 * 100), 0u);          // right of the frame: black
  EXPECT_EQ(word_at(mem, 60 * fb.pitch), 0u);    // below it: black, not stale memory
  EXPECT_NE(r->notes.back().find("black border"), std::string::npos);
}

TEST(KmsOutput, UnsupportedFormatNamesWhatThePlaneOffers) {
  FakeKmsDevice dev;
  dev.set_plane_formats(FakeKmsDevice::kPrimary, {kDrmFormatXrgb8888});
  auto r = KmsOutput(dev).show(hdr10_frame(64, 32));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message, "no primary plane for the CRTC scans out XB30 (offered: XR24)");
}

TEST(KmsOutput, ScrgbIsConvertedToHdr10OrRefused) {
  FakeKmsDevice dev;
  KmsOutput out(dev);
  auto r = out.show(scrgb_frame({{0x3c00, 0x3c00, 0x3c00}, {0x4a40, 0x4a40, 0x4a40}}));  // 80 and 1000 cd/m2 white
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(r->signal, Mode::hdr10);
  EXPECT_EQ(r->fourcc, kDrmFormatXbgr2101010);
  ASSERT_TRUE(r->hdr_metadata);
  EXPECT_EQ(r->hdr_metadata->max_cll, 1000);  // measured on the converted frame
  EXPECT_EQ(r->hdr_metadata->max_fall, 540);  // (80 + 1000) / 2
  EXPECT_NE(r->notes.front().find("scRGB converted to HDR10"), std::string::npos);
  PresentOptions refuse;
  refuse.scrgb = ScrgbPolicy::refuse;
  auto no = KmsOutput(dev).show(scrgb_frame({{0, 0, 0}}), refuse);
  ASSERT_FALSE(no.ok());
  EXPECT_EQ(no.error().code, "scanout.scrgb");
}

TEST(Scanout, ScrgbToHdr10CodesMatchReferenceTable) {
  // REFERENCE.md §2 PQ table, 10-bit full range: 80 -> 497, 100 -> 520, 1000 -> 769, 10000 -> 1023.
  auto in = scrgb_frame({{0x3c00, 0x3c00, 0x3c00}, {0x3d00, 0x3d00, 0x3d00},
                         {0x4a40, 0x4a40, 0x4a40}, {0x57d0, 0x57d0, 0x57d0}, {0xb800, 0, 0}});
  in.target.peak_nits = 10000;  // the table's whole range
  auto f = scrgb_to_hdr10(in);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(word_at(f->data, 0), xbgr(497, 497, 497));
  EXPECT_EQ(word_at(f->data, 4), xbgr(520, 520, 520));
  EXPECT_EQ(word_at(f->data, 8), xbgr(769, 769, 769));
  EXPECT_EQ(word_at(f->data, 12), xbgr(1023, 1023, 1023));
  EXPECT_EQ(word_at(f->data, 16) & 0x3ff, 0u);  // negative light is clipped to black
  EXPECT_DOUBLE_EQ(f->content_light.max_cll_nits, 10000.0);
  // Issue 29 item 2: for a 1000 cd/m2 target, light at and above the peak gets the largest
  // code at or below it (769 = 998.9 cd/m2), never a code above the mastering maximum.
  in.target.peak_nits = 1000;
  auto capped = scrgb_to_hdr10(in);
  ASSERT_TRUE(capped.ok());
  EXPECT_EQ(word_at(capped->data, 12), xbgr(769, 769, 769));
  EXPECT_DOUBLE_EQ(capped->content_light.max_cll_nits, 1000.0);
}

TEST(Scanout, ScrgbRedUsesTheBt2087Matrix) {
  // 1000 cd/m2 Rec.709 red (12.5) in Rec.2020 is 1000 x (0.6274, 0.0691, 0.0164) (BT.2087).
  auto f = scrgb_to_hdr10(scrgb_frame({{0x4a40, 0, 0}}));
  ASSERT_TRUE(f.ok());
  const std::uint32_t v = word_at(f->data, 0);
  auto code = [](double nits) { return transfer::quantize_full(transfer::pq_inverse_eotf(nits), 10); };
  EXPECT_NEAR(int(v & 0x3ff), code(627.4), 1);
  EXPECT_NEAR(int((v >> 10) & 0x3ff), code(69.1), 1);
  EXPECT_NEAR(int((v >> 20) & 0x3ff), code(16.4), 1);
}

TEST(Scanout, NarrowRangeIsExpandedToFull) {
  // BT.2100 Table 9: 10-bit narrow black 64 / peak 940; 100 cd/m2 PQ is 509 narrow, 520 full.
  EncodedFrame f = hdr10_frame(3, 1);
  f.target.range = Range::narrow;
  const std::uint32_t px[3] = {xbgr(64, 940, 509), xbgr(0, 1023, 64), xbgr(509, 509, 509)};
  std::memcpy(f.data.data(), px, sizeof px);
  auto full = narrow_to_full_range(f);
  ASSERT_TRUE(full.ok());
  EXPECT_EQ(word_at(full->data, 0), xbgr(0, 1023, 520));
  EXPECT_EQ(word_at(full->data, 4), xbgr(0, 1023, 0));  // sub-black and super-white clip
  EXPECT_EQ(word_at(full->data, 8), xbgr(520, 520, 520));
  EncodedFrame s = sdr_frame(2, 1);
  s.target.range = Range::narrow;
  const std::uint8_t bytes[8] = {16, 235, 126, 0, 16, 16, 16, 0};
  std::memcpy(s.data.data(), bytes, 8);
  auto sfull = narrow_to_full_range(s);
  EXPECT_EQ(sfull->data[0], 0);
  EXPECT_EQ(sfull->data[1], 255);
  EXPECT_EQ(sfull->data[2], 128);  // (126 - 16) / 219 * 255 = 128.08
  auto prepared = prepare_for_scanout(f, ScrgbPolicy::convert);
  ASSERT_TRUE(prepared.ok());
  EXPECT_EQ(prepared->frame.target.range, Range::full);
  EXPECT_NE(prepared->notes.front().find("full range"), std::string::npos);
}

TEST(Scanout, FramesThatDoNotFitAreRejected) {
  EncodedFrame f = hdr10_frame(8, 8);
  f.data.resize(10);
  EXPECT_EQ(check_frame(f).error().code, "scanout.size");
  f = hdr10_frame(8, 8);
  f.stride_bytes = 4;
  EXPECT_EQ(check_frame(f).error().code, "scanout.stride");
  f = hdr10_frame(8, 8);
  f.drm_fourcc = kDrmFormatXrgb8888;
  EXPECT_EQ(check_frame(f).error().message, "hdr10 frames are XB30, not XR24");
  f.drm_fourcc = fourcc('N', 'V', '1', '2');
  EXPECT_EQ(check_frame(f).error().code, "scanout.format");
}

}  // namespace
}  // namespace hdrd::display
