// JPEG on libjpeg-turbo: the compressor every JPEG hdrd writes goes through, and the plain
// SDR JPEG. libjpeg reports errors through error_exit, which longjmps back here; the function
// that calls setjmp creates no C++ object that a longjmp could skip.
#include <csetjmp>
#include <cstdio>
#include <cstdlib>

#include <fmt/format.h>
#include <jpeglib.h>

#include "encode/io/internal.hpp"
#include "encode/io/io.hpp"
#include "encode/io/stills.hpp"

namespace hdrd::io {
namespace detail {
namespace {

struct JpegError {
  jpeg_error_mgr mgr{};
  std::jmp_buf jump{};
  char message[JMSG_LENGTH_MAX] = {};
};

[[noreturn]] void on_jpeg_error(j_common_ptr cinfo) {
  auto* e = reinterpret_cast<JpegError*>(cinfo->err);
  (*cinfo->err->format_message)(cinfo, e->message);
  std::longjmp(e->jump, 1);
}

struct JpegJob {
  const JpegSamples* image = nullptr;
  int quality = 90;
  bool subsample = true;
  const std::vector<JpegMarker>* markers = nullptr;
  unsigned char* out = nullptr;  // malloc'd by jpeg_mem_dest
  unsigned long out_size = 0;
};

void set_sampling(jpeg_compress_struct& c, bool subsample) {
  if (c.num_components != 3) return;
  c.comp_info[0].h_samp_factor = c.comp_info[0].v_samp_factor = subsample ? 2 : 1;
  for (int i = 1; i < 3; ++i) c.comp_info[i].h_samp_factor = c.comp_info[i].v_samp_factor = 1;
}

bool run_compress(jpeg_compress_struct& c, JpegError& err, JpegJob& job) {
  if (setjmp(err.jump)) return false;
  jpeg_create_compress(&c);
  jpeg_mem_dest(&c, &job.out, &job.out_size);
  const JpegSamples& im = *job.image;
  c.image_width = static_cast<JDIMENSION>(im.width);
  c.image_height = static_cast<JDIMENSION>(im.height);
  c.input_components = im.components;
  c.in_color_space = im.components == 3 ? JCS_RGB : JCS_GRAYSCALE;
  jpeg_set_defaults(&c);
  jpeg_set_quality(&c, job.quality, TRUE);
  set_sampling(c, job.subsample);
  c.optimize_coding = TRUE;  // Huffman tables fitted to the image: ~5 % smaller, baseline still
  jpeg_start_compress(&c, TRUE);
  for (const JpegMarker& m : *job.markers)
    jpeg_write_marker(&c, m.code, m.payload.data(), static_cast<unsigned int>(m.payload.size()));
  const std::size_t stride = static_cast<std::size_t>(im.width) * im.components;
  while (c.next_scanline < c.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(im.rows.data() + c.next_scanline * stride);
    jpeg_write_scanlines(&c, &row, 1);
  }
  jpeg_finish_compress(&c);
  return true;
}

}  // namespace

Result<std::vector<std::uint8_t>> compress_jpeg(const JpegSamples& image, int quality, bool subsample,
                                                const std::vector<JpegMarker>& markers) {
  if (quality < 1 || quality > 100)
    return make_error("jpeg.options", fmt::format("JPEG quality {} is outside 1..100", quality), "jpeg.quality");
  for (const JpegMarker& m : markers)
    if (m.payload.size() > 65533) return make_error("jpeg.encode", "a JPEG marker segment exceeds 65533 bytes");
  JpegJob job{&image, quality, subsample, &markers};
  jpeg_compress_struct c{};
  JpegError err;
  c.err = jpeg_std_error(&err.mgr);
  err.mgr.error_exit = on_jpeg_error;
  const bool ok = run_compress(c, err, job);
  jpeg_destroy_compress(&c);
  std::vector<std::uint8_t> out;
  if (ok) out.assign(job.out, job.out + job.out_size);
  std::free(job.out);
  if (!ok) return make_error("jpeg.encode", fmt::format("libjpeg cannot encode the image: {}", err.message));
  return out;
}

}  // namespace detail

namespace detail {

Result<std::vector<std::uint8_t>> sdr_samples(const EncodedFrame& f) {
  if (f.target.mode != Mode::sdr || f.target.sdr_curve != SdrCurve::srgb)
    return make_error("jpeg.mode",
                      fmt::format("a JPEG carries sRGB: it needs an sdr frame with the srgb curve, not {}{}",
                                  to_string(f.target.mode), f.target.mode == Mode::sdr ? " with gamma22" : ""),
                      "display.mode");
  if (f.target.range != Range::full)
    return make_error("jpeg.range", "a JPEG carries full-range codes: encode the SDR frame with range full",
                      "display.range");
  if (auto ok = detail::check_frame(f); !ok) return ok.error();
  const bool ten = f.drm_fourcc != kDrmFormatXrgb8888;
  std::vector<std::uint8_t> rgb(static_cast<std::size_t>(f.width) * f.height * 3);
  for (int y = 0; y < f.height; ++y) {
    const std::uint8_t* src = f.data.data() + static_cast<std::size_t>(y) * f.stride_bytes;
    std::uint8_t* out = rgb.data() + static_cast<std::size_t>(y) * f.width * 3;
    for (int x = 0; x < f.width; ++x, src += 4, out += 3) {
      if (!ten) {  // XRGB8888: bytes B, G, R, X
        out[0] = src[2], out[1] = src[1], out[2] = src[0];
        continue;
      }
      for (int c = 0; c < 3; ++c) out[c] = static_cast<std::uint8_t>((detail::code_at(f, x, y, c) * 255 + 511) / 1023);
    }
  }
  return rgb;
}

}  // namespace detail

Result<std::vector<std::uint8_t>> encode_jpeg(const EncodedFrame& sdr, const JpegOptions& options) {
  auto rgb = detail::sdr_samples(sdr);
  if (!rgb) return rgb.error();
  return detail::compress_jpeg({sdr.width, sdr.height, 3, *rgb}, options.quality, options.subsample_chroma);
}

}  // namespace hdrd::io
