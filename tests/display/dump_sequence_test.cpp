// The inputs of `hdrd present` for a sequence: a pattern, a directory, a list, the
// sequence sidecar, several sidecars; gaps and inconsistent frames are errors naming the
// file; the sequence's MaxCLL / MaxFALL are the largest of the frames' (CTA-861.3).
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <fmt/format.h>

#include "display/dump_reader.hpp"
#include "display/dump_sequence.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::display {
namespace {

namespace fs = std::filesystem;

// OUTBASE.NNNNN.json + .raw as hdrd render --frames N --format raw writes them.
void write_dump(const fs::path& dir, const std::string& name, int w, int h, double max_cll, double max_fall,
                const char* mode = "hdr10") {
  std::ofstream(dir / (name + ".json"))
      << fmt::format(R"({{"mode": "{}", "fourcc": "XB30", "width": {}, "height": {},
                          "content_light_level": {{"max_cll_nits": {}, "max_fall_nits": {}}}}})",
                     mode, w, h, std::ceil(max_cll), std::ceil(max_fall));
  std::ofstream(dir / (name + ".raw"), std::ios::binary) << std::string(static_cast<std::size_t>(w) * h * 4, '\0');
}

std::vector<std::string> names(const DumpSequence& s) {
  std::vector<std::string> out;
  for (const auto& p : s.sidecars) out.push_back(p.filename().string());
  return out;
}

TEST(DumpSequence, PatternFromTheLowestFrameWithTheLargestLevels) {
  hdrd::testing::TempDir tmp;
  const double cll[] = {120, 940, 300}, fall[] = {80, 60, 210};
  for (int i = 0; i < 3; ++i) write_dump(tmp.path(), fmt::format("walk.{:05d}", i + 7), 4, 2, cll[i], fall[i]);
  std::ofstream(tmp / "walk.json") << "{}";  // not a frame
  const std::vector<std::string> in = {(tmp / "walk.%05d.json").string()};
  EXPECT_TRUE(names_a_dump_sequence(in));
  auto s = open_dump_sequence(in);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(names(*s), (std::vector<std::string>{"walk.00007.json", "walk.00008.json", "walk.00009.json"}));
  EXPECT_DOUBLE_EQ(s->content_light.max_cll_nits, 940);  // brightest pixel of any frame
  EXPECT_DOUBLE_EQ(s->content_light.max_fall_nits, 210);  // brightest frame average, not the average of averages
  EXPECT_EQ(s->width, 4);
  EXPECT_FALSE(s->fps);
}

TEST(DumpSequence, AGapIsAnErrorNamingTheMissingFrame) {
  hdrd::testing::TempDir tmp;
  for (int i : {0, 1, 3}) write_dump(tmp.path(), fmt::format("f.{:05d}", i), 4, 2, 100, 50);
  auto s = open_dump_sequence({(tmp / "f.%05d.json").string()});
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, "dump.sequence");
  EXPECT_NE(s.error().message.find("frame 2 is missing (frames 0..1 exist, then 3)"), std::string::npos)
      << s.error().message;
  auto none = open_dump_sequence({(tmp / "g.%05d.json").string()});
  EXPECT_NE(none.error().message.find("no file matches the pattern"), std::string::npos);
}

TEST(DumpSequence, FramesOfAnotherSizeOrModeAreRefusedBeforeAnythingIsShown) {
  hdrd::testing::TempDir tmp;
  write_dump(tmp.path(), "f.00000", 4, 2, 100, 50);
  write_dump(tmp.path(), "f.00001", 4, 4, 100, 50);
  auto s = open_dump_sequence({(tmp / "f.%05d.json").string()});
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("f.00001.json is 4x4 hdr10; the sequence's first frame"), std::string::npos)
      << s.error().message;
  write_dump(tmp.path(), "f.00001", 4, 2, 100, 50, "hlg");
  EXPECT_FALSE(open_dump_sequence({(tmp / "f.%05d.json").string()}).ok());
  fs::resize_file(tmp / "f.00000.raw", 5);  // a truncated raw: read_dump's error
  EXPECT_EQ(open_dump_sequence({(tmp / "f.00000.json").string(), (tmp / "f.00001.json").string()}).error().code,
            "dump.raw");
}

TEST(DumpSequence, DirectoryListAndSeveralSidecars) {
  hdrd::testing::TempDir tmp;
  fs::create_directories(tmp / "d");
  for (int i = 0; i < 3; ++i) write_dump(tmp / "d", fmt::format("s.{:05d}", i), 4, 2, 100, 50);
  std::ofstream(tmp / "d" / "s.json") << R"({"format": "something else"})";  // no .raw: not a frame
  auto dir = open_dump_sequence({(tmp / "d").string()});
  ASSERT_TRUE(dir.ok()) << dir.error().message;
  EXPECT_EQ(names(*dir), (std::vector<std::string>{"s.00000.json", "s.00001.json", "s.00002.json"}));
  std::ofstream(tmp / "list.txt") << "# reversed\nd/s.00002.json\n\n  d/s.00000.json  \n";
  auto list = open_dump_sequence({(tmp / "list.txt").string()});
  ASSERT_TRUE(list.ok()) << list.error().message;
  EXPECT_EQ(names(*list), (std::vector<std::string>{"s.00002.json", "s.00000.json"}));
  const std::vector<std::string> two = {(tmp.path() / "d/s.00001.json").string(), (tmp.path() / "d/s.00000.json").string()};
  EXPECT_TRUE(names_a_dump_sequence(two));
  EXPECT_EQ(names(*open_dump_sequence(two)), (std::vector<std::string>{"s.00001.json", "s.00000.json"}));
  EXPECT_FALSE(names_a_dump_sequence({(tmp.path() / "d/s.00001.json").string()}));  // one dump: a still
  std::ofstream(tmp / "empty.txt") << "# nothing\n";
  EXPECT_EQ(open_dump_sequence({(tmp / "empty.txt").string()}).error().code, "dump.sequence");
}

TEST(DumpSequence, TheSequenceSidecarGivesFramesFpsAndLevels) {
  // The layout job/sequence writes (docs/sequences.md): format, fps, content_light_level,
  // files.frames.sidecar.
  hdrd::testing::TempDir tmp;
  for (int i = 0; i < 2; ++i) write_dump(tmp.path(), fmt::format("walk.{:05d}", i), 4, 2, 100, 50);
  std::ofstream(tmp / "walk.json") << R"({"format": "hdrd-sequence", "format_version": 1, "fps": 23.976,
      "content_light_level": {"max_cll_nits": 1201, "max_fall_nits": 400, "max_cll_nits_measured": 1200.4,
                              "max_fall_nits_measured": 399.2},
      "files": {"frames": {"raw": "walk.%05d.raw", "sidecar": "walk.%05d.json"}, "sidecar": "walk.json"}})";
  const std::vector<std::string> in = {(tmp / "walk.json").string()};
  EXPECT_TRUE(names_a_dump_sequence(in));
  auto s = open_dump_sequence(in);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->sidecars.size(), 2u);
  EXPECT_DOUBLE_EQ(*s->fps, 23.976);
  EXPECT_DOUBLE_EQ(s->content_light.max_cll_nits, 1200.4);  // the measured value, as read_dump prefers
  EXPECT_DOUBLE_EQ(s->content_light.max_fall_nits, 399.2);
  std::ofstream(tmp / "video.json") << R"({"format": "hdrd-sequence", "files": {"video": "v.mp4"}})";
  auto novideo = open_dump_sequence({(tmp / "video.json").string()});
  ASSERT_FALSE(novideo.ok());
  EXPECT_NE(novideo.error().message.find("render it with --format raw"), std::string::npos);
}

TEST(DumpReader, HeaderReadsNoPixelsButChecksTheRawSize) {
  hdrd::testing::TempDir tmp;
  write_dump(tmp.path(), "a", 4, 2, 100, 50);
  auto h = read_dump_header(tmp / "a.json");
  ASSERT_TRUE(h.ok()) << h.error().message;
  EXPECT_TRUE(h->frame.data.empty());
  EXPECT_EQ(h->raw, tmp / "a.raw");
  EXPECT_EQ(h->frame.stride_bytes, 16u);
  fs::resize_file(tmp / "a.raw", 31);
  EXPECT_EQ(read_dump_header(tmp / "a.json").error().code, "dump.raw");
}

}  // namespace
}  // namespace hdrd::display
