// Fuzz target: any bytes -> the two insertions the video writer makes into encoder output
// (encode/video/bitstream.hpp): the first byte picks HEVC (even) or AV1 (odd), the rest is
// the access unit / temporal unit. An Error must name what is wrong; a success must be the
// input with exactly the inserted bytes added at one place.
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "encode/video/bitstream.hpp"

using namespace hdrd::video;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::span<const std::uint8_t> unit(data + 1, size - 1);
  const bool av1 = data[0] & 1;
  const std::vector<std::uint8_t> ours =
      av1 ? av1_metadata_obu(kAv1MetadataHdrCll, av1_content_light({1000, 400}))
          : hevc_prefix_sei_nal(std::vector<SeiMessage>{{kSeiContentLightLevelInfo, sei_content_light({1000, 400})}});
  const auto out = av1 ? av1_insert_before_frames(unit, ours) : hevc_insert_before_slices(unit, ours);
  if (!out) {
    if (out.error().message.empty() || out.error().code != "video.bitstream") std::abort();
    return 0;
  }
  if (out->size() != unit.size() + ours.size()) std::abort();
  // The first difference is at most ours.size() bytes after where ours went in (ours may
  // begin with the bytes it was put before, e.g. a start code).
  const std::ptrdiff_t first = std::mismatch(unit.begin(), unit.end(), out->begin()).first - unit.begin();
  const auto m = static_cast<std::ptrdiff_t>(ours.size());
  bool found = false;
  for (std::ptrdiff_t k = std::max<std::ptrdiff_t>(0, first - m); k <= first && !found; ++k)
    found = std::equal(ours.begin(), ours.end(), out->begin() + k) &&
            std::equal(unit.begin() + k, unit.end(), out->begin() + k + m);
  if (!found) std::abort();
  return 0;
}
