// Colour grading with LUTs (RTR4 §8.2.3; issue "Colour grading"). The pipeline only sees
// this interface; the .cube / OpenColorIO loaders, shapers and baking live behind it.
#pragma once

#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "encode/io/beneath.hpp"
#include "encode/result.hpp"

namespace hdrd::grade {

enum class Placement {
  scene,    // before tone mapping: relative scene values (Rec.2020, 1.0 = diffuse white),
            // through a declared shaper into [0,1], the LUT, and back
  display,  // after tone mapping: display nits (Rec.2020), PQ-encoded as LUT input
  baked,    // the LUT holds the tone curve too: relative scene values in, display nits out
};

std::string_view to_string(Placement p);
std::optional<Placement> parse_placement(std::string_view s);  // "scene", "display", "baked"

// Shapers map scene-referred values into [0,1] LUT input (RTR4 §8.2.3).
enum class Shaper { pq, log2, sqrt, sqrt_sqrt, none };
std::string_view to_string(Shaper s);
std::optional<Shaper> parse_shaper(std::string_view s);

// A 3D LUT as the GPU samples it (lattice, R fastest), with how its input is shaped.
struct GpuLut {
  int size = 0;
  std::vector<float> rgb;  // size^3 * 3
  Shaper shaper = Shaper::pq;
  double shaper_min = 0, shaper_max = 1;  // shaper domain parameters (e.g. log2 stops)
  // Interpolation the CPU path uses (tetrahedral unless set). LUT output is decoded with the
  // inverse shaper for scene placement and as PQ of display nits for display and baked
  // (docs/grading.md has the shaper formulas).
  bool trilinear = false;
};

class Grade {
 public:
  virtual ~Grade() = default;
  virtual Placement placement() const = 0;
  // Applies in place to `pixels` RGBA float pixels (alpha untouched). Units as Placement says.
  virtual void apply(float* rgba, std::size_t pixels) const = 0;
  // For the sidecar: file, shaper, size, interpolation, placement, baked peak, ...
  virtual nlohmann::json describe() const = 0;
  // A baked LUT is tied to the peak it was baked for.
  virtual std::optional<double> baked_peak_nits() const { return std::nullopt; }
  // The LUT and shaper for the GPU encode pass; nullopt when the grade has no 3D LUT form.
  virtual std::optional<GpuLut> gpu_lut() const { return std::nullopt; }
};

// What a request or the command line asks for.
struct GradeSettings {
  std::string lut_path;                  // .cube, or any format OpenColorIO reads
  std::optional<Shaper> shaper;          // scene placement; default pq
  // The shaper's range when given ("log2:-8:8" -> {-8, 8}; lut.hpp ShaperSpec::min/max),
  // else the one the file records for the same kind, else the kind's default.
  std::optional<std::pair<double, double>> shaper_range;
  Placement placement = Placement::display;
  bool trilinear = false;                // default tetrahedral
  // OpenColorIO config-based grading ($OCIO or explicit path)
  std::string ocio_config;
  std::string ocio_look;
  std::string ocio_colorspace;
  std::string ocio_display, ocio_view;
  // Where lut_path and ocio_config are opened (encode/io/beneath.hpp): beneath the daemon's
  // asset root, or as given. A .cube is read from the descriptor that was checked;
  // OpenColorIO opens its files itself, so those are checked through here just before.
  io::InputFiles files;
  bool empty() const { return lut_path.empty() && ocio_look.empty() && ocio_display.empty() && ocio_colorspace.empty(); }
};

// Loads and validates a grade. `target_peak_nits` is checked against a baked LUT's peak
// (a mismatch is a warning). Errors name the file and line where they apply.
Result<std::shared_ptr<const Grade>> load_grade(const GradeSettings& settings, double target_peak_nits,
                                                std::vector<std::string>* warnings);

}  // namespace hdrd::grade
