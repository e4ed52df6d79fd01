#include "daemon/jobs/memory.hpp"

#include <algorithm>
#include <fstream>

#include <fmt/format.h>

#include "encode/io/io.hpp"
#include "shading/renderer.hpp"

namespace hdrd::daemon {
namespace {

// Bytes per pixel of each stage (the table in memory.hpp).
constexpr std::uint64_t kTargetBpp = 16 + 4;      // RGBA32F colour + DEPTH_COMPONENT32F
constexpr std::uint64_t kMsaaSampleBpp = 16 + 4;  // per sample
constexpr std::uint64_t kFloatBpp = 16;           // RGBA float (readback, decoded EXR, display light)
constexpr std::uint64_t kFrameBpp = 8 + 6;        // encoded frame (up to 8 B/px) + 16-bit PNG samples
constexpr std::uint64_t kRequestTextFactor = 3;   // body, its JSON document, a decoded base64 PNG
constexpr std::uint64_t kPerJobBytes = 32u << 20; // shadow map (2048^2 x 4 B), LUTs, scratch, a first frame's JIT
constexpr std::uint64_t kSceneFileFactor = 4;     // a scene or glTF file: parsed, meshes, their GPU copy
constexpr std::uint64_t kVideoEncoderFixedBytes = 192u << 20;  // estimate_sequence_memory (memory.hpp: measured)
constexpr std::uint64_t kVideoEncoderBpp = 160;
constexpr std::uint64_t kSequenceFrameBytes = 2u << 10;  // per frame: its sidecar entry and light summary (memory.hpp)
constexpr int kMaxMsaaSamples = shading::kMaxSamples;  // what the renderer clamps a request to

bool float_output(std::optional<job::Output> reply) {
  return !reply || *reply == job::Output::exr || *reply == job::Output::scene_exr;  // a dump writes EXRs too
}

// Encode and reply for a w x h frame, with the display light when the answer needs it;
// serialised once: the encoder's buffer moves into the reply body (or is written to a file).
std::uint64_t encode_bytes(std::optional<job::Output> reply, std::uint64_t pixels) {
  const bool floats = float_output(reply);
  return pixels * (kFrameBpp + (floats ? kFloatBpp : 0) + (floats ? 16 : 8));
}

// A setting of the request's source (ui.* is not one of a pattern's).
bool has_value(const job::FrameRequest& r, std::string_view path) {
  return r.values.find(path) != r.values.end() && !r.values.find(path)->second.is_null();
}

std::uint64_t frame_pixels(const job::FrameRequest& r) {
  return std::uint64_t(std::max<std::int64_t>(r.integer("width"), 1)) *
         std::uint64_t(std::max<std::int64_t>(r.integer("height"), 1));
}

// The UI overlay's decoded size, from the PNG's IHDR (uploaded, or the first bytes of the
// file in the asset root), checked against the frame limits before anything is decoded.
Result<std::uint64_t> ui_bytes(const job::FrameRequest& r, const io::InputFiles& files, const Limits& limits) {
  const bool upload = !r.ui_png.empty();
  if (!upload && !has_value(r, "ui.path")) return std::uint64_t{0};
  std::vector<std::uint8_t> head;
  std::uint64_t file_bytes = 0;
  const std::string field = upload ? "ui.png_base64" : "ui.path";
  if (upload) {
    head.assign(r.ui_png.begin(), r.ui_png.begin() + std::ptrdiff_t(std::min<std::size_t>(r.ui_png.size(), 64)));
  } else {
    // Its header only, before the 202, opened as the job opens it (beneath the asset root,
    // no links, never waiting on a FIFO); the job reads it again when it runs.
    const std::filesystem::path path = r.text("ui.path");
    if (auto fd = files.open(path); fd) {
      if (auto bytes = io::read_prefix(fd->get(), path.string(), 64); bytes) head.assign(bytes->begin(), bytes->end());
      if (auto id = io::identity_of(fd->get(), path.string()); id) file_bytes = std::uint64_t(id->size);
    }
  }
  const auto h = io::png_header(head);
  if (!h) return make_error("png.not_png", fmt::format("{}: not a PNG file", field), field);
  const io::PngLimits pl = ui_png_limits(limits);
  const std::int64_t w = h->width, ht = h->height;
  if (w == 0 || ht == 0 || w > pl.max_width || ht > pl.max_height || w * ht > pl.max_pixels)
    return make_error("request.limit", fmt::format("{}: the PNG declares {}x{} pixels; a UI may have at most {}x{} "
                                                   "and {} pixels (limits.max_width/max_height/max_pixels)",
                                                   field, w, ht, pl.max_width, pl.max_height, pl.max_pixels),
                      field);
  return io::overlay_decode_bytes(h->width, h->height) + file_bytes;
}

}  // namespace

std::string format_bytes(std::uint64_t b) {
  if (b >= (1ull << 30)) return fmt::format("{:.1f} GiB", double(b) / double(1ull << 30));
  if (b >= (1ull << 20)) return fmt::format("{:.0f} MiB", double(b) / double(1ull << 20));
  if (b >= (1ull << 10)) return fmt::format("{:.0f} KiB", double(b) / double(1ull << 10));
  return fmt::format("{} B", b);
}

io::PngLimits ui_png_limits(const Limits& limits) { return {limits.max_width, limits.max_height, limits.max_pixels}; }

Result<std::uint64_t> estimate_render_memory(const job::FrameRequest& r, const io::InputFiles& files,
                                             std::optional<job::Output> reply, std::size_t body_bytes,
                                             const Limits& limits) {
  auto ui = ui_bytes(r, files, limits);
  if (!ui) return ui.error();
  const std::uint64_t pixels = frame_pixels(r);
  const int samples = int(std::clamp<std::int64_t>(r.integer("samples"), 1, kMaxMsaaSamples));
  const std::uint64_t msaa = samples > 1 ? pixels * kMsaaSampleBpp * std::uint64_t(samples) : 0;
  std::uint64_t scene_file = 0;
  if (r.scene.kind == job::SceneRef::Kind::file) {
    if (auto fd = files.open(r.scene.path); fd)
      if (auto id = io::identity_of(fd->get(), r.scene.path.string()); id) scene_file = kSceneFileFactor * std::uint64_t(id->size);
  }
  return kPerJobBytes + kRequestTextFactor * body_bytes + scene_file + *ui + pixels * (kTargetBpp + kFloatBpp) + msaa +
         encode_bytes(reply, pixels);
}

Result<std::uint64_t> estimate_encode_memory(const job::FrameRequest& r, const io::InputFiles& files,
                                             std::optional<job::Output> reply, std::span<const std::uint8_t> exr,
                                             const Limits& limits) {
  auto pixels = io::exr_declared_pixels(exr);
  if (!pixels) return pixels.error();
  auto ui = ui_bytes(r, files, limits);
  if (!ui) return ui.error();
  const std::uint64_t px = std::uint64_t(std::max<std::int64_t>(*pixels, 1));
  return kPerJobBytes + exr.size() + *ui + px * kFloatBpp + encode_bytes(reply, px);
}

std::uint64_t estimate_pattern_memory(const job::FrameRequest& r, std::optional<job::Output> reply,
                                      std::size_t body_bytes) {
  const std::uint64_t pixels = frame_pixels(r);
  return kPerJobBytes + kRequestTextFactor * body_bytes + pixels * kFloatBpp + encode_bytes(reply, pixels);
}

Result<std::uint64_t> estimate_sequence_memory(const job::FrameRequest& r, const io::InputFiles& files,
                                               const std::filesystem::path& first_exr,
                                               std::size_t queue_depth, std::size_t body_bytes, const Limits& limits,
                                               int frames) {
  std::uint64_t frame = 0, pixels = 0;
  if (r.source == job::Source::encode) {
    // The header only, before the 202, opened as the job opens its frames.
    auto fd = files.open(first_exr);
    auto id = fd ? io::identity_of(fd->get(), first_exr.string()) : Result<io::FileIdentity>(fd.error());
    auto prefix = id ? io::read_prefix(fd->get(), first_exr.string(), io::kExrHeaderPrefixBytes) : Result<std::string>(id.error());
    if (!prefix) {  // the file model's refusals (a link, a FIFO, a hard link) keep their codes
      Error e = io::reader_error(prefix.error(), "file.unreadable", "file.unreadable", "images");
      if (e.code == "file.unreadable") e.message = fmt::format("images: cannot read {}", first_exr.filename().string());
      return e;
    }
    const std::uint64_t size = std::uint64_t(id->size);
    const std::vector<std::uint8_t> head(prefix->begin(), prefix->end());
    auto e = estimate_encode_memory(r, files, std::nullopt, head, limits);
    if (!e) return e.error();
    auto px = io::exr_declared_pixels(head);
    pixels = px ? std::uint64_t(std::max<std::int64_t>(*px, 1)) : 1;
    frame = *e - head.size() + size;  // the whole file is read for each frame
  } else {
    auto e = estimate_render_memory(r, files, std::nullopt, body_bytes, limits);
    if (!e) return e.error();
    frame = *e;
    pixels = frame_pixels(r);
  }
  const std::uint64_t video = r.is_null("video.codec") ? 0 : kVideoEncoderFixedBytes + pixels * kVideoEncoderBpp;
  return frame * (queue_depth + 2) + video + std::uint64_t(std::max(frames, 0)) * kSequenceFrameBytes;
}

}  // namespace hdrd::daemon
