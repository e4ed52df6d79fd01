// OpenColorIO 2.1 behind a small interface (no OCIO headers leak out of encode/grade/ocio.cpp):
// any LUT format OCIO reads through FileTransform, configs ($OCIO or a path) with looks,
// colour spaces and display/views, and the ACES output transforms built into OCIO 2.1
// registered as tone curves "aces-ocio-*" (platform notes §3).
#pragma once

#include <cstddef>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/colour/color.hpp"
#include "encode/grade/grade.hpp"
#include "encode/grade/lut.hpp"
#include "encode/result.hpp"

namespace hdrd::ocio {

std::string version();  // "2.1.2"

// A CPU processor: const, thread-safe, cheap to copy (shared).
class Processor {
 public:
  lut::Rgb apply(lut::Rgb rgb) const;
  // RGBA float in place (alpha untouched); splits rows over std::threads.
  void apply_rgba(float* rgba, std::size_t pixels, int threads = 1) const;
  bool valid() const { return impl_ != nullptr; }
  struct Impl;
  explicit Processor(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  Processor() = default;

 private:
  std::shared_ptr<const Impl> impl_;
};

// Any file OCIO reads (.cube, .clf/.ctf, .spi3d, .spi1d, .3dl, .csp, .cub, ...) through a
// FileTransform on a raw config. Errors are one line naming the file.
// The bytes of a file already opened through the file model (encode/io/beneath.hpp), whose
// name's extension tells OpenColorIO the format: OpenColorIO reads a private copy of them
// (encode/io/private_copy.hpp), never the path a request named.
Result<Processor> file_transform(std::string_view bytes, const std::filesystem::path& name, lut::Interpolation interp);
// A file of the CLI's user, opened as given (io::open_regular) and read as above.
Result<Processor> file_transform(const std::filesystem::path& path, lut::Interpolation interp);

// A grade built from an OpenColorIO config (GradeSettings::ocio_*):
//   look:               scene placement, working -> look -> working
//   lut + colorspace:   scene placement, working -> colorspace -> LUT -> colorspace -> working
//   display + view:     baked placement, working -> view -> display encoding, decoded back to
//                       display nits in Rec.2020 through the config's cie_xyz_d65_interchange
//   colorspace alone:   the same, when it is a display colour space
// "working" is hdrd's linear Rec.2020 D65 (1.0 = diffuse white): a colour space added to a
// copy of the config from its aces_interchange role, or the named --ocio-colorspace when a
// look or display/view is asked for, or the scene_linear role (with a warning).
struct ConfigGrade {
  Processor processor;
  grade::Placement placement = grade::Placement::scene;
  nlohmann::json description;
};
Result<ConfigGrade> load_config_grade(const grade::GradeSettings& settings, double target_peak_nits,
                                      std::vector<std::string>* warnings);

// ---- ACES output transforms as tone curves -------------------------------------------
struct AcesOutput {
  const char* curve_name;   // "aces-ocio-hdr-1000"
  const char* builtin;      // OCIO 2.1 BuiltinTransform style
  double peak_nits;         // the transform's fixed display peak
  double unit_nits;         // nits of output XYZ Y = 1 (100 for the HDR and SDR video ones)
  // The output transform's display primaries. Its last step clips each linear channel there
  // to [0, peak] (ACES 1.0 ODT.Academy.Rec709_100nits_dim.ctl: clamp_f3(linearCV, 0., 1.));
  // OCIO's built-in stops at XYZ before that clip, and its tone scale rises on above the
  // peak (the ODT spline's slopeHigh of 0.04), so the curve applies the clip itself.
  const color::Primaries* display_primaries;
};
const std::vector<AcesOutput>& aces_outputs();
// Registers every aces_outputs() entry with tonemap::register_curve (idempotent). Also
// run at static initialisation of this file.
void register_tone_curves();

}  // namespace hdrd::ocio
