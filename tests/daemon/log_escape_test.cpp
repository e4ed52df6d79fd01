// The log escaper (daemon/log_escape.hpp). The oracle is written out by hand per input
// (the escape table in the header), plus properties over every byte and byte pair: no
// control byte survives, the output is well-formed UTF-8 by the JSON layer's independent
// check (encode/io/json_text.hpp), and unescaping gives back the input.
#include <gtest/gtest.h>

#include <random>
#include <sstream>
#include <vector>

#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include "daemon/log_escape.hpp"
#include "encode/io/json_text.hpp"

namespace hdrd::daemon {
namespace {

bool has_control_byte(const std::string& s) {
  for (unsigned char c : s)
    if (c < 0x20 || c == 0x7f) return true;
  return false;
}

void expect_clean_round_trip(const std::string& in) {
  const std::string out = escape_log_text(in);
  EXPECT_FALSE(has_control_byte(out)) << out;
  EXPECT_TRUE(io::is_valid_utf8(out)) << out;
  const auto back = unescape_log_text(out);
  ASSERT_TRUE(back.has_value()) << out;
  EXPECT_EQ(*back, in);
}

TEST(LogEscape, EscapesEachClassAsTheTableSays) {
  const std::pair<std::string, std::string> cases[] = {
      {"GET /v1/status", "GET /v1/status"},
      {"a\nb\rc\td", "a\\nb\\rc\\td"},
      {"forged\n2026-01-01T00:00:00.000 info #1 ok", "forged\\n2026-01-01T00:00:00.000 info #1 ok"},
      {std::string("nul\0x", 5), "nul\\x00x"},
      {"\x1b[31mred", "\\x1b[31mred"},
      {"del\x7f", "del\\x7f"},
      {"back\\slash", "back\\\\slash"},
      {"\\x41", "\\\\x41"},                     // an escape-looking text stays distinguishable
      {"caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x8e\xa8", "caf\xc3\xa9 \xe2\x82\xac \xf0\x9f\x8e\xa8"},  // é € 🎨 as they are
      {"\xc2\x9b" "31m", "\\xc2\\x9b31m"},      // U+009B, 8-bit CSI
      {"\xe2\x80\xae" "txt", "\\xe2\\x80\\xaetxt"},  // U+202E RIGHT-TO-LEFT OVERRIDE
      {"\xe2\x80\xa8", "\\xe2\\x80\\xa8"},        // U+2028 LINE SEPARATOR
      {"\xff\xfe", "\\xff\\xfe"},                 // never UTF-8
      {"\xc0\xaf", "\\xc0\\xaf"},                 // overlong '/'
      {"\xed\xa0\x80", "\\xed\\xa0\\x80"},        // a surrogate, U+D800
      {"\xf4\x90\x80\x80", "\\xf4\\x90\\x80\\x80"},  // past U+10FFFF
      {"\xe2\x82", "\\xe2\\x82"},                 // truncated
      {"%0a%1b", "%0a%1b"},                       // percent-escapes are text: the logger sees decoded bytes
  };
  for (const auto& [in, want] : cases) {
    EXPECT_EQ(escape_log_text(in), want);
    expect_clean_round_trip(in);
  }
}

TEST(LogEscape, EveryByteAndBytePairRoundTripsWithoutAControlByte) {
  for (int a = 0; a < 256; ++a) {
    expect_clean_round_trip(std::string(1, char(a)));
    for (int b = 0; b < 256; ++b) expect_clean_round_trip(std::string{char(a), char(b)});
  }
}

// The escaped characters as UTF-8 byte patterns: C2 80..9F (C1), E2 80 A8..AE (U+2028..202E),
// E2 81 A6..A9 (U+2066..2069).
bool has_format_control(const std::string& s) {
  for (std::size_t k = 0; k + 1 < s.size(); ++k) {
    const auto b = [&](std::size_t j) { return k + j < s.size() ? static_cast<unsigned char>(s[k + j]) : 0; };
    if (b(0) == 0xc2 && b(1) >= 0x80 && b(1) <= 0x9f) return true;
    if (b(0) == 0xe2 && b(1) == 0x80 && b(2) >= 0xa8 && b(2) <= 0xae) return true;
    if (b(0) == 0xe2 && b(1) == 0x81 && b(2) >= 0xa6 && b(2) <= 0xa9) return true;
  }
  return false;
}

TEST(LogEscape, WellFormedTextWithoutControlsIsCopiedAsItIs) {
  std::mt19937 rng(28);
  for (int i = 0; i < 50000; ++i) {
    std::string s(std::size_t(rng() % 12), '\0');
    // Half the strings from a small alphabet of multi-byte lead and trail bytes, so that
    // well-formed sequences (and the escaped characters) come up often.
    static const unsigned char kBytes[] = {'a', '/', 0xc2, 0x80, 0x9b, 0xa0, 0xc3, 0xa9, 0xe2, 0x81, 0xa6, 0xae, 0xf0, 0x9f};
    for (char& c : s) c = i % 2 ? char(rng() % 256) : char(kBytes[rng() % sizeof kBytes]);
    const bool plain = io::is_valid_utf8(s) && !has_control_byte(s) && s.find('\\') == std::string::npos &&
                       !has_format_control(s);
    EXPECT_EQ(escape_log_text(s) == s, plain) << escape_log_text(s);
    expect_clean_round_trip(s);
  }
}

TEST(LogEscape, UnescapeRefusesWhatEscapeNeverWrites) {
  for (const std::string& bad : std::vector<std::string>{"\\", "a\\", "\\q", "\\x4", "\\xg0", "\\x4G", "raw\nline", std::string("\x1b")})
    EXPECT_FALSE(unescape_log_text(bad).has_value()) << bad;
}

// The process-wide formatter: what reaches a sink is escaped, the pattern around it is kept.
TEST(LogEscape, TheLogFormatterEscapesEveryMessage) {
  std::ostringstream os;
  auto logger = std::make_shared<spdlog::logger>("log_escape_test", std::make_shared<spdlog::sinks::ostream_sink_mt>(os));
  spdlog::register_logger(logger);
  set_escaped_log_pattern("[%l] %v");
  logger->info("#{} {} {}", 1, "GET", "/v1/status\n[info] forged\x1b[2J");
  logger->error("scene: unknown key '{}'", "\x1b]0;title\x07");
  spdlog::drop("log_escape_test");
  EXPECT_EQ(os.str(), "[info] #1 GET /v1/status\\n[info] forged\\x1b[2J\n"
                      "[error] scene: unknown key '\\x1b]0;title\\x07'\n");
}

}  // namespace
}  // namespace hdrd::daemon
