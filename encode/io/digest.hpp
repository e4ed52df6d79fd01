#pragma once
// A content digest of bytes (an upload, a UI image): XXH3-128 from xxHash, as 32 lowercase
// hex digits. It tells identical inputs apart from different ones (the daemon's coalescing
// key, the request a sidecar records) at memory speed: 27 MB in ~3.5 ms, where the FNV-1a
// it replaces took ~30 ms. It is not a cryptographic hash.
#include <string>
#include <string_view>

namespace hdrd::io {

std::string content_digest(std::string_view bytes);

}  // namespace hdrd::io
