// Fuzz target: query parameters as libmicrohttpd hands them over (percent-decoded bytes:
// any byte, NUL included), through everything the daemon does with them: check_query
// (input_bounds.hpp), query_to_request_json, the request parser, the canonical JSON and
// its key. The JSON is printed strictly (no replacement of invalid UTF-8): a string that
// got through and that nlohmann cannot print was a 500 (issue 14, mode=%ff).
//
// Input: pairs separated by '&', name and value by the first '='; no decoding (the bytes
// are what MHD's decoding produces).
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "daemon/http/input_bounds.hpp"
#include "job/request.hpp"

namespace {

using namespace hdrd;
using namespace hdrd::daemon;

void check(bool ok) {
  if (!ok) std::abort();
}

void check_error(const Error& e) {
  check(!e.code.empty() && !e.message.empty());
  check(e.message.find('\n') == std::string::npos);
  check(io::is_valid_utf8(e.field));  // the JSON error body carries it
}

std::vector<std::pair<std::string, std::string>> split(const std::string& s) {
  std::vector<std::pair<std::string, std::string>> q;
  std::size_t start = 0;
  while (start <= s.size() && q.size() < 2 * kMaxQueryParams) {
    const std::size_t amp = s.find('&', start);
    const std::string item = s.substr(start, amp == std::string::npos ? std::string::npos : amp - start);
    const std::size_t eq = item.find('=');
    q.emplace_back(item.substr(0, eq), eq == std::string::npos ? "" : item.substr(eq + 1));
    if (amp == std::string::npos) break;
    start = amp + 1;
  }
  return q;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto query = split(std::string(reinterpret_cast<const char*>(data), size));
  if (auto ok = check_query(query); !ok) {
    check_error(ok.error());
    return 0;
  }
  auto j = job::query_to_request_json(query);
  if (!j) {
    check_error(j.error());
    return 0;
  }
  (void)j->dump();  // strict: throws (and aborts the fuzzer) on invalid UTF-8
  job::ParseContext ctx;
  ctx.source = job::Source::encode;
  ctx.spelling = job::Spelling::query;
  ctx.reach = job::Reach::daemon;
  auto r = job::parse_request_json(*j, ctx);
  if (!r) {
    check_error(r.error());
    return 0;
  }
  (void)r->canonical().dump();
  return 0;
}
