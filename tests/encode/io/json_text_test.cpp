// Bounded JSON parsing (encode/io/json_text.hpp). Cases from Nicolas Seriot's JSONTestSuite
// (github.com/nst/JSONTestSuite, test_parsing/: n_* must be refused, y_* accepted) and the
// UTF-8 sequences of RFC 3629 §3/§10 and Markus Kuhn's UTF-8 decoder stress test.
#include <gtest/gtest.h>

#include <string>

#include "encode/io/json_text.hpp"

namespace hdrd::io {
namespace {

JsonBounds bounds(int depth = 32, std::size_t bytes = 1 << 20) {
  return JsonBounds{bytes, depth, "request", "request."};
}

TEST(JsonText, AcceptsWhatRfc8259Allows) {
  for (const char* text : {R"({"a":[1,2.5,-3e2,true,false,null,"\u00e9"]})", "[]", "0", R"("x")", " [1] ",
                           "[1e308]", R"({"k":"\ud83d\ude00"})"}) {
    auto r = parse_json_bounded(text, bounds());
    EXPECT_TRUE(r.ok()) << text << ": " << r.error().message;
  }
  auto r = parse_json_bounded(R"({"a":{"b":[10,20]}})", bounds());
  ASSERT_TRUE(r.ok());
  EXPECT_EQ((*r)["a"]["b"][1], 20);
}

// JSONTestSuite n_structure_100000_opening_arrays.json and i_structure_500_nested_arrays.json:
// refused at the limit without building anything, whatever the depth.
TEST(JsonText, DepthIsBoundedWhileReading) {
  for (int depth : {33, 500, 100000}) {
    const std::string text = std::string(std::size_t(depth), '[') + std::string(std::size_t(depth), ']');
    auto r = parse_json_bounded(text, bounds(32));
    ASSERT_FALSE(r.ok()) << depth;
    EXPECT_EQ(r.error().code, "request.depth");
    EXPECT_NE(r.error().message.find("deeper than 32"), std::string::npos) << r.error().message;
    EXPECT_FALSE(check_json_text(text, bounds(32)).ok());
  }
  // An unterminated 100 000-level text (n_structure_100000_opening_arrays) is a depth error too.
  EXPECT_EQ(parse_json_bounded(std::string(100000, '['), bounds(32)).error().code, "request.depth");
  // Exactly at the limit is fine, objects count like arrays.
  EXPECT_TRUE(parse_json_bounded(std::string(32, '[') + std::string(32, ']'), bounds(32)).ok());
  std::string objects;
  for (int i = 0; i < 33; ++i) objects += R"({"k":)";
  objects += "1" + std::string(33, '}');
  auto r = parse_json_bounded(objects, bounds(32));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.depth");
  EXPECT_EQ(r.error().field, "") << "no field is wrong: the nesting is";
  EXPECT_NE(r.error().message.find("(in k.k.k.k"), std::string::npos) << r.error().message;
}

TEST(JsonText, SizeIsCheckedFirst) {
  auto r = parse_json_bounded(std::string(2000, ' ') + "1", bounds(32, 1000));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, "request.too_large");
  EXPECT_NE(r.error().message.find("at most 1000"), std::string::npos) << r.error().message;
}

// JSONTestSuite n_multidigit_number_then_00.json ("123\0") and n_string_unescaped_ctrl_char:
// nlohmann's lexer ends the input at a NUL byte, so what followed would be ignored.
TEST(JsonText, NulBytesAreRefusedWithTheirOffset) {
  for (std::string text : {std::string("123\0", 4), std::string("{\"a\":1}\0{\"b\":2}", 15),
                           std::string("[\"a\0a\"]", 7)}) {
    auto r = parse_json_bounded(text, bounds());
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, "request.syntax");
    EXPECT_NE(r.error().message.find("NUL byte at byte"), std::string::npos) << r.error().message;
  }
}

// i_number_huge_exp.json, i_number_real_pos_overflow.json, i_number_neg_int_huge_exp.json:
// implementation-defined; here they are errors that name the field holding the number.
TEST(JsonText, NumberOverflowNamesTheField) {
  struct Case {
    const char* text;
    const char* field;
  };
  for (const Case& c : {Case{R"({"display":{"peak_nits":5e551}})", "display.peak_nits"},
                        Case{R"({"lights":[{},{},{"intensity":-1e400}]})", "lights[2].intensity"},
                        Case{"[0.4e00669999999999999999999999999999999999999999999999999999999999999]", "[0]"},
                        Case{"1.5e999", ""}}) {
    auto r = parse_json_bounded(c.text, bounds());
    ASSERT_FALSE(r.ok()) << c.text;
    EXPECT_EQ(r.error().code, "request.value") << c.text;
    EXPECT_EQ(r.error().field, c.field) << c.text;
    EXPECT_EQ(r.error().message.find("json.exception"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("range of a double"), std::string::npos) << r.error().message;
  }
}

TEST(JsonText, SyntaxErrorsGiveThePlaceWithoutTheLibraryPrefix) {
  for (const char* text : {R"({"a":1,})", "[1,]", R"({"a" 1})", "[01]", R"(["\x"])", "[1] x", "", "\xff",
                           "[\"\xc0\xaf\"]" /* overlong '/' */, "[\"\xed\xa0\x80\"]" /* surrogate */}) {
    auto r = parse_json_bounded(text, bounds());
    ASSERT_FALSE(r.ok()) << text;
    EXPECT_EQ(r.error().code, "request.syntax") << text;
    EXPECT_EQ(r.error().message.find("[json.exception"), std::string::npos) << r.error().message;
    EXPECT_EQ(r.error().message.find('\n'), std::string::npos) << r.error().message;
  }
  auto r = parse_json_bounded(R"({"display":{"mode":"hdr10",}})", bounds());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("in display"), std::string::npos) << r.error().message;
  EXPECT_EQ(r.error().field, "");
}

TEST(JsonText, Utf8FollowsRfc3629) {
  // Well-formed: ASCII, 2-, 3- and 4-byte forms at their boundaries (U+0080, U+07FF, U+0800,
  // U+FFFF, U+10000, U+10FFFF), and the RFC's own examples (§7).
  for (const char* ok : {"", "abc", "\xc2\x80", "\xdf\xbf", "\xe0\xa0\x80", "\xef\xbf\xbf", "\xf0\x90\x80\x80",
                         "\xf4\x8f\xbf\xbf", "\x41\xe2\x89\xa2\xce\x91\x2e", "\xed\x95\x9c\xea\xb5\xad\xec\x96\xb4",
                         "\xe6\x97\xa5\xe6\x9c\xac\xe8\xaa\x9e", "\xef\xbb\xbf\xf0\xa3\x8e\xb4"})
    EXPECT_TRUE(is_valid_utf8(ok)) << ok;
  // Ill-formed (Kuhn §3-§5): lone continuation, truncated sequences, overlong forms of '/'
  // and of U+0000, surrogates U+D800/U+DFFF, above U+10FFFF, the bytes C0, C1, F5..FF.
  for (const char* bad : {"\x80", "\xbf", "\xc2", "\xe0\xa0", "\xf0\x90\x80", "\xc0\xaf", "\xe0\x80\xaf",
                          "\xf0\x80\x80\xaf", "\xc1\xbf", "\xed\xa0\x80", "\xed\xbf\xbf", "\xf4\x90\x80\x80",
                          "\xf5\x80\x80\x80", "\xfe", "\xff", "a\xff", "%ff"})
    EXPECT_EQ(is_valid_utf8(bad), std::string_view(bad) == "%ff") << bad;
  EXPECT_FALSE(is_valid_utf8(std::string_view("\xc0\x80", 2)));
  EXPECT_TRUE(is_valid_utf8(std::string_view("a\0b", 3)));  // NUL is a character; callers refuse it separately
}

}  // namespace
}  // namespace hdrd::io
