#include "encode/video/writer.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <vector>

#include <fmt/format.h>

extern "C" {
#include <libavutil/mastering_display_metadata.h>
#include <libavutil/opt.h>
}

#include "encode/io/io.hpp"
#include "encode/io/signal_metadata.hpp"
#include "encode/parallel.hpp"
#include "encode/video/bitstream.hpp"
#include "encode/video/encoder_config.hpp"
#include "encode/video/libav.hpp"
#include "encode/video/ycbcr.hpp"

namespace hdrd::video {

namespace fs = std::filesystem;

// ---- names --------------------------------------------------------------------------------

std::string_view to_string(Codec c) {
  switch (c) {
    case Codec::hevc: return "hevc";
    case Codec::av1: return "av1";
    case Codec::h264: return "h264";
  }
  return "?";
}
std::string_view to_string(Container c) { return c == Container::mp4 ? "mp4" : "mkv"; }
std::optional<Codec> parse_codec(std::string_view s) {
  if (s == "hevc" || s == "h265") return Codec::hevc;
  if (s == "av1") return Codec::av1;
  if (s == "h264" || s == "avc") return Codec::h264;
  return std::nullopt;
}
std::optional<Container> parse_container(std::string_view s) {
  if (s == "mp4") return Container::mp4;
  if (s == "mkv" || s == "matroska") return Container::mkv;
  return std::nullopt;
}
std::string_view file_extension(Container c) { return c == Container::mp4 ? ".mp4" : ".mkv"; }

nlohmann::json VideoResult::to_json() const {
  nlohmann::json j{{"file", path.string()},
                   {"codec", codec},
                   {"encoder", encoder},
                   {"profile", profile},
                   {"pixel_format", pixel_format},
                   {"colour_primaries", colour_primaries},
                   {"transfer_characteristics", transfer_characteristics},
                   {"matrix_coefficients", matrix_coefficients},
                   {"range", range},
                   {"frames", frames},
                   {"bytes", bytes},
                   {"hdr10plus", hdr10plus}};
  if (content_light)
    j["content_light_level"] = {{"max_cll_nits", content_light->max_cll_nits}, {"max_fall_nits", content_light->max_fall_nits}};
  return j;
}

void quiet_codec_logs() {
  lav::quiet_logs();  // applied when the libraries are loaded, if they are not yet
  ::setenv("SVT_LOG", "1", 0);  // SVT-AV1's own logger: 1 = errors
}

// ---- libav plumbing ---------------------------------------------------------------------------

namespace {

std::string av_error_text(int err) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {};
  lav::av_strerror(err, buf, sizeof buf);
  return buf;
}

Error av_fail(const char* code, const std::string& what, int err) {
  return make_error(code, fmt::format("{}: {}", what, av_error_text(err)));
}

// A libav call that failed while writing `path`: a full file system is io.no_space (AVIO
// hands the failed write's AVERROR(ENOSPC) back from av_write_frame, the trailer or the
// close), anything else `code`.
Error av_write_fail(const char* code, const fs::path& path, const std::string& what, int err) {
  if (err == AVERROR(ENOSPC) || err == AVERROR(EDQUOT)) return io::write_error(path, what, AVUNERROR(err));
  return av_fail(code, what, err);
}

struct CodecContextFree {
  void operator()(AVCodecContext* c) const { lav::avcodec_free_context(&c); }
};
struct FrameFree {
  void operator()(AVFrame* f) const { lav::av_frame_free(&f); }
};
struct PacketFree {
  void operator()(AVPacket* p) const { lav::av_packet_free(&p); }
};
struct FileClose {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using CodecContextPtr = std::unique_ptr<AVCodecContext, CodecContextFree>;
using FramePtr = std::unique_ptr<AVFrame, FrameFree>;
using PacketPtr = std::unique_ptr<AVPacket, PacketFree>;
using FilePtr = std::unique_ptr<std::FILE, FileClose>;

// The output muxer; frees the context and closes its file.
struct Muxer {
  AVFormatContext* ctx = nullptr;
  ~Muxer() {
    if (!ctx) return;
    if (ctx->pb) lav::avio_closep(&ctx->pb);
    lav::avformat_free_context(ctx);
  }
};

// A spooled packet: its header, then its bytes.
struct SpoolRecord {
  std::int64_t pts = 0, dts = 0, duration = 0;
  std::int32_t flags = 0;
  std::uint32_t size = 0;
};

Result<void> fsync_path(const fs::path& p) {
  const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return io::write_error(p, "cannot reopen it", errno);
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) return io::write_error(p, "fsync failed", err);
  return {};
}

}  // namespace

// ---- the writer ----------------------------------------------------------------------------------

struct SequenceWriter::Impl {
  VideoSettings settings;
  StreamInfo stream;
  EncoderConfig config;
  YcbcrFormat ycbcr;
  fs::path output, output_temp, spool_path;
  CodecContextPtr enc;
  FramePtr frame;
  PacketPtr packet;
  FilePtr spool;
  int frames = 0;
  // Frames asked to be keyframes and the pts of the key packets the encoder made: a request
  // it did not honour is said in VideoResult::warnings (scene cuts a player cannot seek to).
  std::vector<std::int64_t> requested_keyframes;
  std::set<std::int64_t> key_pts;
  ContentLightLevel frames_light;  // from EncodedFrame::content_light, when no metadata is given
  double convert_ms = 0, encoder_ms = 0, mux_ms = 0;  // wall time in each stage (VideoResult)
  double convert_cpu_ms = 0;
  bool failed = false, done = false;
  bool opened = false, flushed = false;  // the encoder's state, for close_encoder()
  // The stream's parameter sets when the encoder delivers them with its first packet
  // (AV_PKT_DATA_NEW_EXTRADATA: FFmpeg 5.1's libaom-av1 does) instead of at open: the
  // Matroska muxer refuses AV1 without them ("Invalid data"), MP4 took them from packet 0.
  std::vector<std::uint8_t> packet_extradata;
  // Packets in the spool, in decode order, and the reorder depth they need: the largest
  // (decode index - pts) over them (pts are frame indices). copy_packets() gives packet n
  // dts = n - reorder_delay, hdrd's own timestamps: libx265 3.5 computes its first dts from
  // m_bframeDelayTime, which it sets only once the (bframes delay + 1)-th frame arrives, so
  // a sequence of 1 or 2 frames got dts from an uninitialised member (issue 28.8: MP4's
  // "pts/dts pair unsupported" about 1 run in 30).
  std::int64_t spooled_packets = 0, reorder_delay = 0;

  void note_spooled(std::int64_t pts) {
    reorder_delay = std::max(reorder_delay, spooled_packets - pts);
    ++spooled_packets;
  }

  // The stream's parameter sets (extradata), from the encoder's context or its first packet.
  std::span<const std::uint8_t> parameter_sets() const {
    if (enc && enc->extradata_size > 0) return {enc->extradata, static_cast<std::size_t>(enc->extradata_size)};
    return packet_extradata;
  }

  ~Impl() { remove_files(); }

  void remove_files() {
    spool.reset();
    close_encoder();
    for (const fs::path* p : {&spool_path, &output_temp})
      if (!p->empty()) ::unlink(p->c_str());
    spool_path.clear();
    output_temp.clear();
  }

  // SVT-AV1 1.4 under FFmpeg 5.1 waits forever in svt_av1_enc_deinit() unless it has
  // seen the end of the stream, so an encoder that is closed early is flushed first (its
  // packets are dropped). The others close at once.
  void close_encoder() {
    if (enc && opened && !flushed && config.encoder == "libsvtav1") {
      flushed = true;
      if (lav::avcodec_send_frame(enc.get(), nullptr) >= 0)
        while (lav::avcodec_receive_packet(enc.get(), packet.get()) >= 0) lav::av_packet_unref(packet.get());
    }
    enc.reset();
  }

  Result<void> open_spool() {
    auto fd = io::create_temp_file(output, spool_path);
    if (!fd) return fd.error();
    ::close(*fd);  // created write-only; the spool is read back in finish()
    spool.reset(std::fopen(spool_path.c_str(), "w+b"));
    if (!spool) return io::write_error(spool_path, "cannot open the spool file", errno);
    return {};
  }

  Result<void> spool_packets() {
    for (;;) {
      const int rc = lav::avcodec_receive_packet(enc.get(), packet.get());
      if (rc == AVERROR(EAGAIN) || rc == AVERROR_EOF) return {};
      if (rc < 0) return av_fail("video.encoder", fmt::format("{} failed", config.encoder), rc);
      if (packet_extradata.empty()) {
        std::size_t n = 0;
        if (const std::uint8_t* d = lav::av_packet_get_side_data(packet.get(), AV_PKT_DATA_NEW_EXTRADATA, &n); d && n > 0)
          packet_extradata.assign(d, d + n);
      }
      if (packet->pts < 0 || packet->pts >= frames) {
        const std::int64_t pts = packet->pts;
        lav::av_packet_unref(packet.get());
        return make_error("video.encoder", fmt::format("{} gave a packet for frame {} of {}", config.encoder, pts, frames));
      }
      note_spooled(packet->pts);
      SpoolRecord r{packet->pts, packet->dts, packet->duration, packet->flags, static_cast<std::uint32_t>(packet->size)};
      if (packet->flags & AV_PKT_FLAG_KEY) key_pts.insert(packet->pts);
      const bool ok = std::fwrite(&r, sizeof r, 1, spool.get()) == 1 &&
                      std::fwrite(packet->data, 1, static_cast<std::size_t>(packet->size), spool.get()) ==
                          static_cast<std::size_t>(packet->size);
      const int err = errno;
      lav::av_packet_unref(packet.get());
      if (!ok) return io::write_error(spool_path, "cannot write the spool file", err);
    }
  }

  Result<void> check_frame(const EncodedFrame& f) const {
    if (f.width != stream.width || f.height != stream.height)
      return make_error("video.frame", fmt::format("frame {} is {}x{}, the video {}x{}", frames, f.width, f.height,
                                                   stream.width, stream.height), "size");
    if (f.target.mode != stream.target.mode || f.target.range != stream.target.range)
      return make_error("video.frame", fmt::format("frame {} is {} ({} range), the video {} ({} range)", frames,
                                                   to_string(f.target.mode), to_string(f.target.range),
                                                   to_string(stream.target.mode), to_string(stream.target.range)),
                        "display.mode");
    return {};
  }

  Result<void> encode(const EncodedFrame& f, const FrameOptions& o) {
    if (auto ok = check_frame(f); !ok) return ok;
    if (const int rc = lav::av_frame_make_writable(frame.get()); rc < 0) return av_fail("video.encoder", "frame buffer", rc);
    const Planes420 planes{{frame->data[0], frame->linesize[0]}, {frame->data[1], frame->linesize[1]},
                           {frame->data[2], frame->linesize[2]}};
    const auto t0 = std::chrono::steady_clock::now();
    {
      const CpuMeter cpu;
      if (auto ok = rgb_to_ycbcr420(f, ycbcr, planes); !ok) return ok;
      convert_cpu_ms += cpu.ms();
    }
    const auto t1 = std::chrono::steady_clock::now();
    convert_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
    frame->pts = frames;
    frame->pict_type = o.keyframe ? AV_PICTURE_TYPE_I : AV_PICTURE_TYPE_NONE;
    if (o.keyframe) requested_keyframes.push_back(frames);
    if (const int rc = lav::avcodec_send_frame(enc.get(), frame.get()); rc < 0)
      return av_fail("video.encoder", fmt::format("{} refused frame {}", config.encoder, frames), rc);
    frames_light.max_cll_nits = std::max(frames_light.max_cll_nits, f.content_light.max_cll_nits);
    frames_light.max_fall_nits = std::max(frames_light.max_fall_nits, f.content_light.max_fall_nits);
    ++frames;
    auto spooled = spool_packets();
    encoder_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
    return spooled;
  }

  Result<VideoResult> mux(const SequenceMetadata* meta);
  Result<void> write_segment(const fs::path& segment);
  Result<void> append_segment(const fs::path& segment, int index);
  Result<AVStream*> start_muxer(Muxer& m, const io::Cta861Light& cll);
  Result<void> copy_packets(Muxer& m, AVStream* st, const SequenceMetadata* meta, const io::Cta861Light& cll);
  VideoResult result(const SequenceMetadata* meta, const io::Cta861Light& cll) const;
  Result<std::vector<std::uint8_t>> with_metadata(const SpoolRecord& r, std::vector<std::uint8_t> data,
                                                  const SequenceMetadata* meta, const io::Cta861Light& cll) const;
};

Result<void> check_stream(const VideoSettings& settings, const StreamInfo& stream) {
  if (auto ok = validate(settings); !ok) return ok;
  auto config = encoder_config(settings, stream);
  if (!config) return config.error();
  return {};
}

Result<std::unique_ptr<SequenceWriter>> SequenceWriter::open(const fs::path& outbase, const VideoSettings& settings,
                                                             const StreamInfo& stream) {
  if (auto loaded = lav::load(); !loaded) return loaded.error();
  auto impl = std::make_unique<Impl>();
  impl->settings = settings;
  impl->stream = stream;
  auto config = encoder_config(settings, stream);
  if (!config) return config.error();
  impl->config = std::move(*config);
  impl->ycbcr.bits = impl->config.bits;
  impl->ycbcr.range = settings.range;
  impl->ycbcr.luma = stream.target.mode == Mode::hdr10 || stream.target.mode == Mode::hlg ? color::kRec2020Luma
                                                                                          : color::kRec709Luma;
  impl->output = fs::path(outbase.string() + std::string(file_extension(settings.container)));

  const AVCodec* codec = lav::avcodec_find_encoder_by_name(impl->config.encoder.c_str());
  if (!codec)
    return make_error("video.encoder", fmt::format("this libavcodec has no {} encoder", impl->config.encoder), "video.codec");
  impl->enc.reset(lav::avcodec_alloc_context3(codec));
  impl->frame.reset(lav::av_frame_alloc());
  impl->packet.reset(lav::av_packet_alloc());
  if (!impl->enc || !impl->frame || !impl->packet) return make_error("video.encoder", "out of memory");
  if (auto ok = configure(impl->config, settings, stream, *impl->enc); !ok) return ok.error();
  AVDictionary* opts = nullptr;
  for (const auto& [k, v] : impl->config.options) lav::av_dict_set(&opts, k.c_str(), v.c_str(), 0);
  const int rc = lav::avcodec_open2(impl->enc.get(), codec, &opts);
  AVDictionaryEntry* unused = lav::av_dict_get(opts, "", nullptr, AV_DICT_IGNORE_SUFFIX);
  const std::string unused_key = unused ? unused->key : "";
  lav::av_dict_free(&opts);
  if (rc < 0) return av_fail("video.encoder", fmt::format("cannot open {}", impl->config.encoder), rc);
  impl->opened = true;
  if (!unused_key.empty())
    return make_error("video.encoder", fmt::format("{} does not take the option {}", impl->config.encoder, unused_key));

  AVFrame* f = impl->frame.get();
  f->format = impl->enc->pix_fmt;
  f->width = stream.width;
  f->height = stream.height;
  if (const int r = lav::av_frame_get_buffer(f, 0); r < 0) return av_fail("video.encoder", "frame buffer", r);
  if (auto ok = impl->open_spool(); !ok) return ok.error();
  return std::unique_ptr<SequenceWriter>(new SequenceWriter(std::move(impl)));
}

SequenceWriter::SequenceWriter(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SequenceWriter::~SequenceWriter() = default;

int SequenceWriter::frames_written() const { return impl_->frames; }
const fs::path& SequenceWriter::output_path() const { return impl_->output; }

Result<void> SequenceWriter::write(const EncodedFrame& frame, const FrameOptions& options) {
  if (impl_->done || impl_->failed)
    return make_error("video.state", impl_->done ? "the video is already finished" : "the writer failed earlier");
  auto ok = impl_->encode(frame, options);
  if (!ok) impl_->failed = true;
  return ok;
}

void SequenceWriter::cancel() {
  impl_->failed = true;
  impl_->remove_files();
}

Result<VideoResult> SequenceWriter::finish(const SequenceMetadata* metadata) {
  if (impl_->done || impl_->failed)
    return make_error("video.state", impl_->done ? "the video is already finished" : "the writer failed earlier");
  auto r = impl_->mux(metadata);
  if (!r) {
    impl_->failed = true;
    impl_->remove_files();
    return r;
  }
  impl_->done = true;
  return r;
}

// ---- segments of a sharded sequence ----------------------------------------------------------

namespace {
// A segment file: the magic, the encoder's parameter sets (extradata), the frame count,
// then the spool's records (SpoolRecord + bytes) with frame-local timestamps.
constexpr char kSegmentMagic[8] = {'H', 'D', 'R', 'D', 'V', 'S', 'G', '1'};
constexpr std::uint32_t kMaxExtradata = 1u << 20;
}  // namespace

Result<void> SequenceWriter::Impl::write_segment(const fs::path& segment) {
  if (frames == 0) return make_error("video.empty", "a video segment needs at least one frame", "frames");
  flushed = true;
  if (const int rc = lav::avcodec_send_frame(enc.get(), nullptr); rc < 0) return av_fail("video.encoder", "flush", rc);
  if (auto ok = spool_packets(); !ok) return ok.error();
  if (std::fflush(spool.get()) != 0 || std::fseek(spool.get(), 0, SEEK_SET) != 0)
    return io::write_error(spool_path, "cannot flush and rewind the spool file", errno);
  fs::path temp;
  auto fd = io::create_temp_file(segment, temp);
  if (!fd) return fd.error();
  FilePtr out(::fdopen(*fd, "wb"));
  if (!out) {
    ::close(*fd);
    ::unlink(temp.c_str());
    return io::write_error(temp, "cannot open it", errno);
  }
  const std::span<const std::uint8_t> params = parameter_sets();
  const std::uint32_t extra = static_cast<std::uint32_t>(params.size());
  const std::uint32_t count = static_cast<std::uint32_t>(frames);
  bool ok = std::fwrite(kSegmentMagic, sizeof kSegmentMagic, 1, out.get()) == 1 &&
            std::fwrite(&extra, sizeof extra, 1, out.get()) == 1 &&
            (extra == 0 || std::fwrite(params.data(), 1, extra, out.get()) == extra) &&
            std::fwrite(&count, sizeof count, 1, out.get()) == 1;
  std::vector<char> buf(1 << 16);
  while (ok) {
    const std::size_t n = std::fread(buf.data(), 1, buf.size(), spool.get());
    if (n == 0) break;
    ok = std::fwrite(buf.data(), 1, n, out.get()) == n;
  }
  ok = ok && std::fflush(out.get()) == 0 && ::fsync(::fileno(out.get())) == 0;
  int err = errno;
  if (std::fclose(out.release()) != 0 && ok) ok = false, err = errno;
  if (!ok || ::rename(temp.c_str(), segment.c_str()) != 0) {
    if (ok) err = errno;
    ::unlink(temp.c_str());
    return io::write_error(segment, "cannot write the segment", err);
  }
  spool.reset();
  ::unlink(spool_path.c_str());
  spool_path.clear();
  return {};
}

// Appends a segment's packets to this writer's spool, its timestamps moved after the
// frames already there (the time base is one tick per frame).
Result<void> SequenceWriter::Impl::append_segment(const fs::path& segment, int index) {
  const std::string name = fmt::format("segment {} ({})", index, segment.filename().string());
  FilePtr in(std::fopen(segment.c_str(), "rb"));
  if (!in) return make_error("video.segment", fmt::format("{}: cannot open: {}", name, std::strerror(errno)));
  char magic[sizeof kSegmentMagic];
  std::uint32_t extra = 0, count = 0;
  if (std::fread(magic, sizeof magic, 1, in.get()) != 1 || std::memcmp(magic, kSegmentMagic, sizeof magic) != 0)
    return make_error("video.segment", name + ": not an hdrd video segment");
  if (std::fread(&extra, sizeof extra, 1, in.get()) != 1 || extra > kMaxExtradata)
    return make_error("video.segment", name + ": truncated or corrupt header");
  std::vector<std::uint8_t> params(extra);
  if (std::fread(params.data(), 1, extra, in.get()) != extra || std::fread(&count, sizeof count, 1, in.get()) != 1)
    return make_error("video.segment", name + ": truncated header");
  // An encoder that delivers its parameter sets with its first packet has none before it
  // has encoded: the first segment's are the stream's, and every later one must match them.
  if (index == 0 && parameter_sets().empty()) packet_extradata = params;
  const std::span<const std::uint8_t> mine = parameter_sets();
  if (extra != mine.size() || (extra > 0 && std::memcmp(params.data(), mine.data(), extra) != 0))
    return make_error("video.segment", name + ": encoded with other parameters (its parameter sets differ from this "
                                              "sequence's settings)");
  const std::int64_t offset = frames;
  std::uint32_t packets = 0;
  for (;;) {
    SpoolRecord r;
    const std::size_t got = std::fread(&r, 1, sizeof r, in.get());
    if (got == 0 && std::feof(in.get())) break;
    if (got != sizeof r || r.size > (1u << 28))
      return make_error("video.segment", fmt::format("{}: corrupt at packet {}", name, packets));
    std::vector<std::uint8_t> data(r.size);
    if (std::fread(data.data(), 1, data.size(), in.get()) != data.size())
      return make_error("video.segment", fmt::format("{}: truncated at packet {}", name, packets));
    if (r.pts < 0 || r.pts >= count)
      return make_error("video.segment", fmt::format("{}: packet {} is for frame {} of {}", name, packets, r.pts, count));
    r.pts += offset, r.dts += offset;
    note_spooled(r.pts);
    if (std::fwrite(&r, sizeof r, 1, spool.get()) != 1 || std::fwrite(data.data(), 1, data.size(), spool.get()) != data.size())
      return io::write_error(spool_path, "cannot write the spool file", errno);
    ++packets;
  }
  if (packets != count) return make_error("video.segment", fmt::format("{}: {} packets for {} frames", name, packets, count));
  frames += static_cast<int>(count);
  return {};
}

Result<void> SequenceWriter::finish_segment(const fs::path& segment) {
  if (impl_->done || impl_->failed)
    return make_error("video.state", impl_->done ? "the video is already finished" : "the writer failed earlier");
  auto ok = impl_->write_segment(segment);
  impl_->failed = !ok;
  impl_->done = ok.ok();
  if (!ok) impl_->remove_files();
  return ok;
}

Result<VideoResult> SequenceWriter::join_segments(const fs::path& outbase, const VideoSettings& settings,
                                                  const StreamInfo& stream, std::span<const fs::path> segments,
                                                  const SequenceMetadata& metadata) {
  if (segments.empty()) return make_error("video.segment", "no segments to join");
  auto w = open(outbase, settings, stream);
  if (!w) return w.error();
  for (std::size_t i = 0; i < segments.size(); ++i)
    if (auto ok = (*w)->impl_->append_segment(segments[i], static_cast<int>(i)); !ok) return ok.error();
  return (*w)->finish(&metadata);
}

// ---- the second pass: mux with the final metadata ---------------------------------------------

Result<std::vector<std::uint8_t>> SequenceWriter::Impl::with_metadata(const SpoolRecord& r, std::vector<std::uint8_t> data,
                                                                      const SequenceMetadata* meta,
                                                                      const io::Cta861Light& cll) const {
  const bool hdr = stream.target.mode == Mode::hdr10 || stream.target.mode == Mode::hlg;
  const bool key = r.flags & AV_PKT_FLAG_KEY;
  const bool dynamic = meta && settings.dynamic_metadata && meta->has_dynamic_metadata() && settings.codec != Codec::h264;
  if (!hdr || (!key && !dynamic)) return data;
  std::vector<std::uint8_t> t35;
  if (dynamic) {
    if (r.pts < 0 || r.pts >= meta->frame_count())
      return make_error("video.mux", fmt::format("packet for frame {} outside the {} frames", r.pts, meta->frame_count()));
    t35 = hdr10plus_t35(meta->hdr10plus(static_cast<int>(r.pts)));
  }
  if (settings.codec == Codec::av1) {
    std::vector<std::uint8_t> obus;
    auto append = [&](std::vector<std::uint8_t> o) { obus.insert(obus.end(), o.begin(), o.end()); };
    if (key) {
      append(av1_metadata_obu(kAv1MetadataHdrMdcv, av1_mastering_display(stream.mastering)));
      append(av1_metadata_obu(kAv1MetadataHdrCll, av1_content_light(cll)));
    }
    if (dynamic) append(av1_metadata_obu(kAv1MetadataItutT35, t35));
    return av1_insert_before_frames(data, obus);
  }
  std::vector<SeiMessage> sei;
  if (key) {
    sei.push_back({kSeiMasteringDisplayColourVolume, sei_mastering_display(io::st2086_codes(stream.mastering))});
    sei.push_back({kSeiContentLightLevelInfo, sei_content_light(cll)});
  }
  if (dynamic) sei.push_back({kSeiUserDataRegisteredT35, t35});
  return hevc_insert_before_slices(data, hevc_prefix_sei_nal(sei));
}

namespace {

bool is_hdr(Mode m) { return m == Mode::hdr10 || m == Mode::hlg; }

// The container's mdcv / clli (MP4) and MasteringMetadata / MaxCLL / MaxFALL (Matroska):
// rationals over the units of ST 2086 / CTA-861.3, so the muxers write the same integers.
Result<void> add_static_side_data(AVStream* st, const MasteringDisplay& mastering, const io::Cta861Light& cll) {
  const io::St2086Codes c = io::st2086_codes(mastering);
  auto* md = reinterpret_cast<AVMasteringDisplayMetadata*>(
      lav::av_stream_new_side_data(st, AV_PKT_DATA_MASTERING_DISPLAY_METADATA, sizeof(AVMasteringDisplayMetadata)));
  auto* cl = reinterpret_cast<AVContentLightMetadata*>(
      lav::av_stream_new_side_data(st, AV_PKT_DATA_CONTENT_LIGHT_LEVEL, sizeof(AVContentLightMetadata)));
  if (!md || !cl) return make_error("video.mux", "out of memory");
  std::memset(md, 0, sizeof *md);
  const std::array<std::array<std::uint16_t, 2>, 3> rgb{c.red, c.green, c.blue};
  for (std::size_t i = 0; i < 3; ++i)
    for (std::size_t k = 0; k < 2; ++k) md->display_primaries[i][k] = av_make_q(rgb[i][k], 50000);
  md->white_point[0] = av_make_q(c.white[0], 50000);
  md->white_point[1] = av_make_q(c.white[1], 50000);
  md->max_luminance = av_make_q(static_cast<int>(c.max_luminance), 10000);
  md->min_luminance = av_make_q(static_cast<int>(c.min_luminance), 10000);
  md->has_primaries = md->has_luminance = 1;
  cl->MaxCLL = cll.max_cll;
  cl->MaxFALL = cll.max_fall;
  return {};
}

}  // namespace

Result<AVStream*> SequenceWriter::Impl::start_muxer(Muxer& m, const io::Cta861Light& cll) {
  const char* format = settings.container == Container::mp4 ? "mp4" : "matroska";
  if (const int rc = lav::avformat_alloc_output_context2(&m.ctx, nullptr, format, output_temp.c_str()); rc < 0)
    return av_fail("video.mux", fmt::format("no {} muxer", format), rc);
  m.ctx->flags |= AVFMT_FLAG_BITEXACT;  // no tool versions or times: the same frames give the same bytes
  AVStream* st = lav::avformat_new_stream(m.ctx, nullptr);
  if (!st) return make_error("video.mux", "out of memory");
  if (const int rc = lav::avcodec_parameters_from_context(st->codecpar, enc.get()); rc < 0)
    return av_fail("video.mux", "stream parameters", rc);
  if (st->codecpar->extradata_size == 0 && !packet_extradata.empty()) {
    auto* d = static_cast<std::uint8_t*>(lav::av_mallocz(packet_extradata.size() + AV_INPUT_BUFFER_PADDING_SIZE));
    if (!d) return make_error("video.mux", "out of memory");
    std::memcpy(d, packet_extradata.data(), packet_extradata.size());
    st->codecpar->extradata = d;  // freed with the stream
    st->codecpar->extradata_size = static_cast<int>(packet_extradata.size());
  }
  // hvc1: parameter sets only in the sample entry (what Apple players require).
  if (settings.codec == Codec::hevc && settings.container == Container::mp4) st->codecpar->codec_tag = MKTAG('h', 'v', 'c', '1');
  st->time_base = enc->time_base;
  st->avg_frame_rate = enc->framerate;
  if (is_hdr(stream.target.mode))
    if (auto ok = add_static_side_data(st, stream.mastering, cll); !ok) return ok.error();
  if (const int rc = lav::avio_open(&m.ctx->pb, output_temp.c_str(), AVIO_FLAG_WRITE); rc < 0)
    return av_write_fail("io.write", output_temp, fmt::format("cannot write {}", output_temp.string()), rc);
  AVDictionary* opts = nullptr;
  // moov first, so a player (or a browser fetching GET /v1/jobs/{id}/result) starts at once.
  if (settings.container == Container::mp4) lav::av_dict_set(&opts, "movflags", "+faststart", 0);
  const int rc = lav::avformat_write_header(m.ctx, &opts);
  lav::av_dict_free(&opts);
  if (rc < 0) return av_write_fail("video.mux", output, fmt::format("cannot start the {} file", format), rc);
  return st;
}

// Every spooled packet, with its metadata inserted, into the muxer.
Result<void> SequenceWriter::Impl::copy_packets(Muxer& m, AVStream* st, const SequenceMetadata* meta,
                                                const io::Cta861Light& cll) {
  PacketPtr out(lav::av_packet_alloc());
  if (!out) return make_error("video.mux", "out of memory");
  for (int n = 0;; ++n) {
    SpoolRecord r;
    if (std::fread(&r, sizeof r, 1, spool.get()) != 1) return {};
    std::vector<std::uint8_t> data(r.size);
    if (std::fread(data.data(), 1, data.size(), spool.get()) != data.size())
      return make_error("io.read", fmt::format("spool file {} is truncated at packet {}", spool_path.string(), n));
    auto bytes = with_metadata(r, std::move(data), meta, cll);
    if (!bytes) return bytes.error();
    if (const int rc = lav::av_new_packet(out.get(), static_cast<int>(bytes->size())); rc < 0) return av_fail("video.mux", "packet", rc);
    std::memcpy(out->data, bytes->data(), bytes->size());
    out->pts = r.pts, out->dts = n - reorder_delay, out->duration = r.duration, out->flags = r.flags;
    out->stream_index = 0;
    lav::av_packet_rescale_ts(out.get(), enc->time_base, st->time_base);
    if (const int rc = lav::av_write_frame(m.ctx, out.get()); rc < 0)
      return av_write_fail("video.mux", output, fmt::format("packet {}", n), rc);
    lav::av_packet_unref(out.get());
  }
}

VideoResult SequenceWriter::Impl::result(const SequenceMetadata* meta, const io::Cta861Light& cll) const {
  VideoResult v;
  v.path = output;
  v.convert_ms = convert_ms;
  v.convert_cpu_ms = convert_cpu_ms;
  v.encoder_ms = encoder_ms;
  v.mux_ms = mux_ms;
  v.codec = std::string(to_string(settings.codec));
  v.encoder = config.encoder;
  v.profile = config.profile;
  v.pixel_format = config.bits == 10 ? "yuv420p10le" : "yuv420p";
  v.colour_primaries = config.tags.primaries;
  v.transfer_characteristics = config.tags.transfer;
  v.matrix_coefficients = config.matrix;
  v.range = std::string(to_string(settings.range));
  v.frames = frames;
  std::error_code ec;
  v.bytes = fs::file_size(output, ec);
  if (is_hdr(stream.target.mode)) v.content_light = ContentLightLevel{static_cast<double>(cll.max_cll), static_cast<double>(cll.max_fall)};
  v.hdr10plus = meta && settings.dynamic_metadata && meta->has_dynamic_metadata() && settings.codec != Codec::h264;
  std::string missed;
  int missed_count = 0;
  for (const std::int64_t f : requested_keyframes)
    if (!key_pts.count(f) && ++missed_count <= 8) missed += (missed.empty() ? "" : ", ") + std::to_string(f);
  if (missed_count > 0)
    v.warnings.push_back(fmt::format("{} made no keyframe at {} of the {} frames asked for (scene starts): frame{} {}{}; "
                                     "a player seeking there starts at an earlier keyframe",
                                     config.encoder, missed_count, requested_keyframes.size(), missed_count == 1 ? "" : "s",
                                     missed, missed_count > 8 ? ", ..." : ""));
  return v;
}

Result<VideoResult> SequenceWriter::Impl::mux(const SequenceMetadata* meta) {
  if (frames == 0) return make_error("video.empty", "a video needs at least one frame", "frames");
  if (meta && meta->frame_count() != frames)
    return make_error("video.metadata", fmt::format("metadata covers {} frames, the video has {}", meta->frame_count(), frames));
  flushed = true;
  const auto t0 = std::chrono::steady_clock::now();
  if (const int rc = lav::avcodec_send_frame(enc.get(), nullptr); rc < 0) return av_fail("video.encoder", "flush", rc);
  if (auto ok = spool_packets(); !ok) return ok.error();
  const auto t1 = std::chrono::steady_clock::now();
  encoder_ms += std::chrono::duration<double, std::milli>(t1 - t0).count();
  if (std::fflush(spool.get()) != 0 || std::fseek(spool.get(), 0, SEEK_SET) != 0)
    return io::write_error(spool_path, "cannot flush and rewind the spool file", errno);

  const io::Cta861Light cll = io::cta861_light(meta ? meta->content_light() : frames_light, stream.mastering);
  auto fd = io::create_temp_file(output, output_temp);
  if (!fd) return fd.error();
  ::close(*fd);
  {
    Muxer m;
    auto st = start_muxer(m, cll);
    if (!st) return st.error();
    if (auto ok = copy_packets(m, *st, meta, cll); !ok) return ok.error();
    if (const int rc = lav::av_write_trailer(m.ctx); rc < 0) return av_write_fail("video.mux", output, "cannot finish the file", rc);
    if (const int rc = lav::avio_closep(&m.ctx->pb); rc < 0) return av_write_fail("io.write", output, "close", rc);
  }
  spool.reset();
  ::unlink(spool_path.c_str());
  spool_path.clear();
  if (auto ok = fsync_path(output_temp); !ok) return ok.error();
  if (::rename(output_temp.c_str(), output.c_str()) != 0)
    return io::write_error(output, fmt::format("cannot rename {} to it", output_temp.string()), errno);
  output_temp.clear();
  mux_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t1).count();
  return result(meta, cll);
}

}  // namespace hdrd::video
