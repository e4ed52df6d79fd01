#include "encode/io/json_text.hpp"

#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include <fmt/format.h>

namespace hdrd::io {
namespace {

using nlohmann::json;

// One open array or object on the way to the current value.
struct Level {
  bool array = false;
  std::string key;        // object: the key of the value being read
  std::size_t index = 0;  // array: the index of the value being read
};

std::string path_of(const std::vector<Level>& path) {
  std::string out;
  for (const auto& l : path) {
    if (l.array) out += fmt::format("[{}]", l.index);
    else out += (out.empty() ? "" : ".") + l.key;
  }
  return out;
}

// nlohmann's messages start with "[json.exception.parse_error.101] "; the rest is ours to show.
std::string library_detail(const char* what) {
  std::string s(what);
  if (const auto close = s.find("] "); !s.empty() && s.front() == '[' && close != std::string::npos) s.erase(0, close + 2);
  for (char& c : s)
    if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = ' ';
  return s;
}

// SAX events from nlohmann's (iterative) parser: the depth is bounded as the text is
// read, the path is kept for error messages, and the document is built only when asked.
class BoundedSax {
 public:
  BoundedSax(const JsonBounds& b, json* doc) : bounds_(b) {
    if (doc) dom_.emplace(*doc, false);
  }

  bool null() { return value([&] { return dom_->null(); }); }
  bool boolean(bool v) { return value([&] { return dom_->boolean(v); }); }
  bool number_integer(json::number_integer_t v) { return value([&] { return dom_->number_integer(v); }); }
  bool number_unsigned(json::number_unsigned_t v) { return value([&] { return dom_->number_unsigned(v); }); }
  bool number_float(json::number_float_t v, const json::string_t& s) { return value([&] { return dom_->number_float(v, s); }); }
  bool string(json::string_t& v) { return value([&] { return dom_->string(v); }); }
  bool binary(json::binary_t& v) { return value([&] { return dom_->binary(v); }); }

  bool start_object(std::size_t n) { return open(false) && (!dom_ || dom_->start_object(n)); }
  bool start_array(std::size_t n) { return open(true) && (!dom_ || dom_->start_array(n)); }
  bool key(json::string_t& k) {
    path_.back().key = k;
    return !dom_ || dom_->key(k);
  }
  bool end_object() { return close([&] { return dom_->end_object(); }); }
  bool end_array() { return close([&] { return dom_->end_array(); }); }

  bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& e) {
    const std::string field = path_of(path_);
    if (e.id == 406) {  // out_of_range.406: a number that overflows a double
      error_ = make_error(code("value"),
                          one_line(fmt::format("{}: {}: a number beyond the range of a double (about 1.8e308)",
                                               bounds_.what, field.empty() ? "value" : field)),
                          field);
    } else {  // the place, not a field: the field itself is not what is wrong
      // One line whatever the keys hold (a key may be "a\nb").
      error_ = make_error(code("syntax"), one_line(fmt::format("{}: not valid JSON near byte {}{}: {}", bounds_.what, position,
                                                               where(field), library_detail(e.what()))));
    }
    return false;
  }

  const std::optional<Error>& error() const { return error_; }

 private:
  std::string code(std::string_view suffix) const { return std::string(bounds_.code_prefix) + std::string(suffix); }

  template <class F>
  bool value(F&& build) {
    if (dom_ && !build()) return false;
    if (!path_.empty() && path_.back().array) ++path_.back().index;
    return true;
  }
  static std::string where(const std::string& path) {
    if (path.empty()) return {};
    return " (in " + (path.size() > 80 ? path.substr(0, 60) + "..." : path) + ")";
  }
  bool open(bool array) {
    if (int(path_.size()) >= bounds_.max_depth) {
      error_ = make_error(code("depth"), one_line(fmt::format("{}: JSON nested deeper than {} levels{}", bounds_.what,
                                                              bounds_.max_depth, where(path_of(path_)))));
      return false;
    }
    path_.push_back({array, {}, 0});
    return true;
  }
  template <class F>
  bool close(F&& build) {
    path_.pop_back();
    return value(build);
  }

  const JsonBounds& bounds_;
  std::optional<nlohmann::detail::json_sax_dom_parser<json>> dom_;
  std::vector<Level> path_;
  std::optional<Error> error_;
};

Result<void> run(std::string_view text, const JsonBounds& b, json* doc) {
  if (text.size() > b.max_bytes)
    return make_error(std::string(b.code_prefix) + "too_large",
                      fmt::format("{}: {} bytes of JSON, at most {}", b.what, text.size(), b.max_bytes));
  // nlohmann's lexer takes a NUL byte for the end of the input: what follows one would be
  // ignored without a word.
  if (const void* nul = std::memchr(text.data(), 0, text.size()))
    return make_error(std::string(b.code_prefix) + "syntax",
                      fmt::format("{}: a NUL byte at byte {} (JSON text cannot contain one)", b.what,
                                  static_cast<const char*>(nul) - text.data()));
  BoundedSax sax(b, doc);
  const bool ok = json::sax_parse(text.begin(), text.end(), &sax, json::input_format_t::json, true, false);
  if (sax.error()) return *sax.error();
  if (!ok) return make_error(std::string(b.code_prefix) + "syntax", fmt::format("{}: not valid JSON", b.what));
  return {};
}

}  // namespace

Result<nlohmann::json> parse_json_bounded(std::string_view text, const JsonBounds& bounds) {
  json doc;
  if (auto r = run(text, bounds, &doc); !r) return r.error();
  return doc;
}

Result<void> check_json_text(std::string_view text, const JsonBounds& bounds) { return run(text, bounds, nullptr); }

bool is_valid_utf8(std::string_view s) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const auto* end = p + s.size();
  while (p < end) {
    const unsigned c = *p;
    if (c < 0x80) {
      ++p;
      continue;
    }
    // RFC 3629 §4: the second byte's range depends on the first (overlongs, surrogates, > U+10FFFF).
    int n = 0;
    unsigned lo = 0x80, hi = 0xbf;
    if (c >= 0xc2 && c <= 0xdf) n = 1;
    else if (c == 0xe0) n = 2, lo = 0xa0;
    else if (c >= 0xe1 && c <= 0xec) n = 2;
    else if (c == 0xed) n = 2, hi = 0x9f;
    else if (c >= 0xee && c <= 0xef) n = 2;
    else if (c == 0xf0) n = 3, lo = 0x90;
    else if (c >= 0xf1 && c <= 0xf3) n = 3;
    else if (c == 0xf4) n = 3, hi = 0x8f;
    else return false;
    if (end - p <= n) return false;
    if (p[1] < lo || p[1] > hi) return false;
    for (int i = 2; i <= n; ++i)
      if (p[i] < 0x80 || p[i] > 0xbf) return false;
    p += n + 1;
  }
  return true;
}

}  // namespace hdrd::io
