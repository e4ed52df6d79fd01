#pragma once
// FFmpeg's libraries, opened the first time a video is written instead of at every process
// start. libavformat and what it links (network protocols, subtitle renderers, ...) are
// about 130 of the 170 shared libraries an hdrd process would otherwise map, ~25 ms of every
// start, and only video needs them (docs/performance.md "Process start").
//
// Every libav function hdrd calls is listed once, in HDRD_LIBAV_FUNCTIONS; lav::NAME(...)
// calls it through the table load() filled in. Call load() before anything else here.
extern "C" {
#include <libavcodec/avcodec.h>
#include <libavformat/avformat.h>
#include <libavutil/dict.h>
#include <libavutil/error.h>
#include <libavutil/frame.h>
#include <libavutil/log.h>
}

#include <utility>

#include "encode/result.hpp"

#define HDRD_LIBAV_FUNCTIONS(X)                                                                       \
  X(av_dict_free) X(av_dict_get) X(av_dict_set) X(av_frame_alloc) X(av_frame_free)                    \
  X(av_frame_get_buffer) X(av_frame_make_writable) X(av_log_set_level) X(av_mallocz) X(av_new_packet) \
  X(av_packet_alloc) X(av_packet_free) X(av_packet_get_side_data) X(av_packet_rescale_ts)             \
  X(av_packet_unref) X(av_stream_new_side_data) X(av_strerror) X(av_write_frame) X(av_write_trailer)  \
  X(avcodec_alloc_context3) X(avcodec_find_encoder_by_name) X(avcodec_free_context) X(avcodec_open2)  \
  X(avcodec_parameters_from_context) X(avcodec_receive_packet) X(avcodec_send_frame)                  \
  X(avformat_alloc_output_context2) X(avformat_free_context) X(avformat_new_stream)                   \
  X(avformat_write_header) X(avio_closep) X(avio_open)

namespace hdrd::video::lav {

struct Functions {
#define HDRD_LIBAV_POINTER(name) decltype(&::name) name = nullptr;
  HDRD_LIBAV_FUNCTIONS(HDRD_LIBAV_POINTER)
#undef HDRD_LIBAV_POINTER
};

// Opens libavutil, libavcodec and libavformat of the major versions hdrd was compiled
// against (Debian 12: .57, .59, .59), once per process, and resolves every function.
// Error video.libav names the library or function that is missing.
Result<void> load();

// The table; only valid after load() succeeded.
const Functions& table();

// Codec logs at errors only, now or as soon as the libraries are loaded.
void quiet_logs();

#define HDRD_LIBAV_FORWARDER(name) \
  template <class... A>            \
  decltype(auto) name(A&&... a) {  \
    return table().name(std::forward<A>(a)...); \
  }
HDRD_LIBAV_FUNCTIONS(HDRD_LIBAV_FORWARDER)
#undef HDRD_LIBAV_FORWARDER

}  // namespace hdrd::video::lav
