// .cube parsing and writing: the Adobe Cube LUT Specification 1.0 keywords, Resolve's
// 1D-shaper + 3D files, exact round trips, and line-numbered errors for malformed files.
#include <gtest/gtest.h>
#include <fmt/format.h>

#include <random>

#include "encode/grade/lut.hpp"
#include "tests/encode/grade/grade_testing.hpp"
#include "tests/testing/testing.hpp"

using namespace hdrd;
using namespace hdrd::lut;

namespace {

// The 2^3 example from the Adobe specification (§ "Example 3D LUT"), with a comment,
// blank lines and CRLF line ends.
constexpr const char* kAdobeExample =
    "# Created by hand\r\n"
    "TITLE \"Example 2x2x2\"\r\n"
    "\r\n"
    "LUT_3D_SIZE 2\r\n"
    "DOMAIN_MIN 0.0 0.0 0.0\r\n"
    "DOMAIN_MAX 1.0 1.0 1.0\r\n"
    "0 0 0\r\n1 0 0\r\n0 .75 0\r\n1 .75 0\r\n0 .25 1\r\n1 .25 1\r\n0 1 1\r\n1 1 1\r\n";

TEST(Cube, ParsesAdobeExample) {
  auto c = parse_cube(kAdobeExample, "example.cube");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_EQ(c->title, "Example 2x2x2");
  ASSERT_EQ(c->comments.size(), 1u);
  EXPECT_EQ(c->comments[0], "Created by hand");
  ASSERT_TRUE(c->lut3d);
  EXPECT_FALSE(c->lut1d);
  EXPECT_EQ(c->lut3d->size, 2);
  EXPECT_TRUE(c->lut3d->domain.is_unit());
  // Red fastest: entry (r=0, g=1, b=0) is the third line.
  const float* e = &c->lut3d->rgb[c->lut3d->index(0, 1, 0)];
  EXPECT_FLOAT_EQ(e[1], 0.75f);
  EXPECT_FLOAT_EQ(c->lut3d->rgb[c->lut3d->index(1, 0, 1) + 1], 0.25f);
}

TEST(Cube, ParsesResolveShaperPlus3D) {
  // The example from Resolve's LUT notes: a 6-entry inverting 1D shaper, then a 3^3 table.
  std::string text = "LUT_1D_SIZE 6\nLUT_1D_INPUT_RANGE 0.0 1.0\nLUT_3D_SIZE 3\nLUT_3D_INPUT_RANGE 0.0 2.0\n";
  for (int i = 0; i < 6; ++i) text += fmt::format("{} {} {}\n", 1 - i * 0.2, 1 - i * 0.2, 1 - i * 0.2);
  for (int i = 0; i < 27; ++i) text += "0.5 0.5 0.5\n";
  auto c = parse_cube(text);
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_TRUE(c->lut1d && c->lut3d);
  EXPECT_EQ(c->lut1d->size, 6);
  EXPECT_FLOAT_EQ(c->lut1d->rgb[3], 0.8f);
  EXPECT_EQ(c->lut3d->domain.max, (Rgb{2, 2, 2}));
  EXPECT_TRUE(c->lut1d->domain.is_unit());
}

TEST(Cube, OneDimensionalWithDomain) {
  auto c = parse_cube("LUT_1D_SIZE 2\nDOMAIN_MIN -1 0 0\nDOMAIN_MAX 1 2 4\n0 0 0\n1 1 1\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  ASSERT_TRUE(c->lut1d);
  EXPECT_EQ(c->lut1d->domain.min, (Rgb{-1, 0, 0}));
  EXPECT_EQ(c->lut1d->domain.max, (Rgb{1, 2, 4}));
  // x = 0 sits in the middle of R's domain, a quarter of B's.
  const auto v = eval(*c, {0.0f, 1.0f, 1.0f}, Interpolation::tetrahedral);
  EXPECT_FLOAT_EQ(v[0], 0.5f);
  EXPECT_FLOAT_EQ(v[1], 0.5f);
  EXPECT_FLOAT_EQ(v[2], 0.25f);
}

TEST(Cube, AcceptsNumberForms) {
  auto c = parse_cube("LUT_3D_SIZE 2\n+1 -0 1e-3\n1.5E+2 .5 5.\n" + std::string(6 * 1, ' ') +
                      "0 0 0\n0 0 0\n0 0 0\n0 0 0\n0 0 0\n0\t0\t0\n");
  ASSERT_TRUE(c.ok()) << c.error().message;
  EXPECT_FLOAT_EQ(c->lut3d->rgb[2], 1e-3f);
  EXPECT_FLOAT_EQ(c->lut3d->rgb[3], 150.0f);
  EXPECT_FLOAT_EQ(c->lut3d->rgb[5], 5.0f);
}

CubeFile random_cube(std::mt19937& rng, bool with1d, bool with3d, bool domains) {
  CubeFile c;
  c.title = "random look";
  c.comments = {"made by cube_test", "", "HDRD_SHAPER log2:-10:6"};
  if (with1d) c.lut1d = grade_testing::random_lut1d(17 + int(rng() % 40), rng);
  if (with3d) c.lut3d = grade_testing::random_lut3d(2 + int(rng() % 12), rng);
  if (domains) {
    std::uniform_real_distribution<float> u(-2.0f, 2.0f);
    const auto set = [&](Domain& d, bool uniform) {
      const float lo = u(rng), hi = lo + 0.5f + std::fabs(u(rng));
      d.min = {lo, uniform ? lo : lo - 0.25f, lo};
      d.max = {hi, hi, uniform ? hi : hi * 2 + 1};
    };
    if (c.lut1d) set(c.lut1d->domain, with3d);
    if (c.lut3d) set(c.lut3d->domain, with1d);
  }
  return c;
}

TEST(Cube, WriteParseRoundTripIsExact) {
  std::mt19937 rng(7);
  for (int i = 0; i < 24; ++i) {
    const bool with1d = i % 3 != 1, with3d = i % 3 != 0, domains = i % 2 == 1;
    const CubeFile c = random_cube(rng, with1d, with3d, domains);
    auto text = format_cube(c);
    ASSERT_TRUE(text.ok()) << text.error().message;
    auto back = parse_cube(*text);
    ASSERT_TRUE(back.ok()) << back.error().message << "\n" << text->substr(0, 400);
    EXPECT_EQ(*back, c) << "case " << i;  // every float bit-exact
    auto again = format_cube(*back);
    ASSERT_TRUE(again.ok());
    EXPECT_EQ(*again, *text);
  }
}

TEST(Cube, WriteFileAndReadBack) {
  hdrd::testing::TempDir dir;
  std::mt19937 rng(3);
  const CubeFile c = random_cube(rng, false, true, true);
  ASSERT_TRUE(write_cube(c, dir / "a.cube").ok());
  auto back = read_cube(dir / "a.cube");
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(*back, c);
}

TEST(Cube, WriterRefusesWhatItCannotExpress) {
  CubeFile c;
  EXPECT_FALSE(format_cube(c).ok());  // no table
  c.lut3d = Lut3D::identity(2);
  c.title = "bad \"quote\"";
  EXPECT_EQ(format_cube(c).error().code, "cube.syntax");
  c.title.clear();
  c.lut3d->rgb[4] = std::nanf("");
  EXPECT_EQ(format_cube(c).error().code, "cube.value");
  c.lut3d = Lut3D::identity(2);
  c.lut1d = Lut1D::identity(4);
  c.lut1d->domain.max = {1, 2, 1};  // non-uniform domain cannot be a LUT_1D_INPUT_RANGE
  EXPECT_EQ(format_cube(c).error().code, "cube.domain");
}

struct BadCube {
  const char* name;
  std::string text;
  int line;
  const char* code;
  const char* says;
};

std::string table(int entries, const char* line = "0 0 0\n") {
  std::string s;
  for (int i = 0; i < entries; ++i) s += line;
  return s;
}

// Every malformed case names its line: "bad.cube:LINE: ...".
TEST(Cube, MalformedFilesGetLineNumberedErrors) {
  const std::vector<BadCube> cases = {
      {"no size", "# nothing\n\n", 2, "cube.syntax", "no LUT_1D_SIZE or LUT_3D_SIZE"},
      {"data before size", "TITLE \"x\"\n0 0 0\n", 2, "cube.syntax", "before LUT_1D_SIZE"},
      {"3D too large", "# big\nLUT_3D_SIZE 257\n", 2, "cube.size", "outside 2..256"},
      {"3D too small", "LUT_3D_SIZE 1\n", 1, "cube.size", "outside 2..256"},
      {"1D too large", "LUT_1D_SIZE 65537\n", 1, "cube.size", "outside 2..65536"},
      {"size not integer", "LUT_3D_SIZE 2.5\n", 1, "cube.syntax", "not an integer"},
      {"size two tokens", "LUT_3D_SIZE 2 2\n", 1, "cube.syntax", "takes one integer"},
      {"unknown keyword", "LUT_3D_SIZE 2\nLUT_4D_SIZE 3\n", 2, "cube.syntax", "unknown keyword 'LUT_4D_SIZE'"},
      {"2D table", "LUT_2D_SIZE 2\n", 1, "cube.syntax", "LUT_2D_SIZE"},
      {"duplicate size", "LUT_3D_SIZE 2\nLUT_3D_SIZE 2\n", 2, "cube.syntax", "given twice"},
      {"unquoted title", "TITLE hello\nLUT_3D_SIZE 2\n", 1, "cube.syntax", "double-quoted"},
      {"title stray quote", "TITLE \"a\"b\"\n", 1, "cube.syntax", "double-quoted"},
      {"domain two numbers", "LUT_3D_SIZE 2\nDOMAIN_MIN 0 0\n", 2, "cube.syntax", "three numbers"},
      {"domain not number", "LUT_3D_SIZE 2\nDOMAIN_MAX 1 x 1\n", 2, "cube.syntax", "'x' is not a finite number"},
      {"domain inverted", "LUT_3D_SIZE 2\nDOMAIN_MIN 0 0 0\nDOMAIN_MAX 1 0 1\n" + table(8), 3, "cube.domain",
       "channel G"},
      {"input range inverted", "LUT_1D_SIZE 2\nLUT_1D_INPUT_RANGE 1 0\n", 2, "cube.domain", "below max"},
      {"domain with both tables", "LUT_1D_SIZE 2\nLUT_3D_SIZE 2\nDOMAIN_MIN 0 0 0\n" + table(10), 3,
       "cube.syntax", "ambiguous"},
      {"range for missing table", "LUT_3D_SIZE 2\nLUT_1D_INPUT_RANGE 0 1\n" + table(8), 2, "cube.syntax",
       "does not declare"},
      {"two values", "LUT_3D_SIZE 2\n0 0 0\n0 0\n", 3, "cube.syntax", "expected 3 numbers"},
      {"four values", "LUT_3D_SIZE 2\n0 0 0 0\n", 2, "cube.syntax", "got 4"},
      {"text in data", "LUT_3D_SIZE 2\n0 0 0\n0 zero 0\n", 3, "cube.syntax", "'zero' is not a number"},
      {"hex value", "LUT_3D_SIZE 2\n0x1 0 0\n", 2, "cube.syntax", "'0x1' is not a number"},
      {"nan value", "LUT_3D_SIZE 2\n0 0 0\nnan 0 0\n", 3, "cube.value", "not finite"},
      {"inf value", "LUT_3D_SIZE 2\n0 0 0\n0 0 1e99\n", 3, "cube.value", "not finite"},
      {"keyword after data", "LUT_3D_SIZE 2\n0 0 0\nTITLE \"late\"\n", 3, "cube.syntax", "after the table data"},
      {"header only", "LUT_1D_SIZE 3\n", 1, "cube.size", "file ends after 0 entries"},
      {"too few entries", "LUT_3D_SIZE 2\n" + table(7) + "\n# end\n", 10, "cube.size", "after 7 entries"},
      {"too many entries", "LUT_3D_SIZE 2\n" + table(9), 10, "cube.size", "more entries than declared"},
      {"too few 1D+3D", "LUT_1D_SIZE 3\nLUT_3D_SIZE 2\n" + table(10), 12, "cube.size", "declares 11"},
      {"binary", std::string("LUT_3D_SIZE 2\n0 0\0 0\n", 21), 2, "cube.syntax", "NUL byte"},
  };
  for (const auto& bc : cases) {
    auto r = parse_cube(bc.text, "bad.cube");
    ASSERT_FALSE(r.ok()) << bc.name;
    const std::string prefix = fmt::format("bad.cube:{}: ", bc.line);
    EXPECT_EQ(r.error().message.rfind(prefix, 0), 0u) << bc.name << ": " << r.error().message;
    EXPECT_EQ(r.error().code, bc.code) << bc.name << ": " << r.error().message;
    EXPECT_NE(r.error().message.find(bc.says), std::string::npos) << bc.name << ": " << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << bc.name;
  }
}

TEST(Cube, MissingFileIsAnError) {
  auto r = read_cube("/nonexistent/look.cube");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "cube.io");
  EXPECT_NE(r.error().message.find("/nonexistent/look.cube"), std::string::npos);
}

}  // namespace
