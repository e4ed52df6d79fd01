// Internal to the video writer: which libavcodec encoder, with which options, for a
// VideoSettings and a stream; every check of the combination, naming what is wrong.
#pragma once

#include <map>
#include <string>

#include "encode/io/signal_metadata.hpp"
#include "encode/result.hpp"
#include "encode/video/writer.hpp"

struct AVCodecContext;

namespace hdrd::video {

struct EncoderConfig {
  std::string encoder;                       // libavcodec encoder name
  int bits = 10;                             // Y'CbCr depth: the frames' depth
  std::string profile;                       // as ffprobe names it
  H273 tags;                             // colour primaries, transfer
  int matrix = io::kH273MatrixBt2020Ncl;     // matrix coefficients
  int keyframe_interval = 48;                // frames
  std::map<std::string, std::string> options;  // AVOptions for avcodec_open2
};

Result<EncoderConfig> encoder_config(const VideoSettings& settings, const StreamInfo& stream);
// Sets the codec context's size, rate, pixel format, colour tags, GOP and threads.
Result<void> configure(const EncoderConfig& config, const VideoSettings& settings, const StreamInfo& stream,
                       AVCodecContext& ctx);

}  // namespace hdrd::video
