// Grading LUTs (RTR4 §8.2.3): 1D and 3D tables, the .cube format (Adobe "Cube LUT
// Specification 1.0" plus Resolve's LUT_*_INPUT_RANGE and 1D-shaper + 3D files), the
// shapers that take scene values into a LUT's [0,1] input, and a fast CPU applier.
//
// Interpolation follows OpenColorIO's Lut3DOp (tetrahedral default, trilinear option),
// so a .cube applied here and through OCIO's FileTransform agree to float rounding.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "encode/grade/grade.hpp"
#include "encode/io/beneath.hpp"
#include "encode/result.hpp"
#include "encode/tone/tonemap.hpp"

namespace hdrd::lut {

enum class Interpolation { tetrahedral, trilinear };
std::string_view to_string(Interpolation i);

using Rgb = std::array<float, 3>;

// Input domain of a table: input x maps to lattice coordinate (x - min) / (max - min).
struct Domain {
  Rgb min{0, 0, 0};
  Rgb max{1, 1, 1};
  bool is_unit() const { return min == Rgb{0, 0, 0} && max == Rgb{1, 1, 1}; }
  bool is_uniform() const { return min[0] == min[1] && min[1] == min[2] && max[0] == max[1] && max[1] == max[2]; }
  friend bool operator==(const Domain&, const Domain&) = default;
};

// Adobe Cube 1.0 limits; 3D tables larger than 256^3 (50 million entries) are refused.
inline constexpr int kMin1DSize = 2;
inline constexpr int kMax1DSize = 65536;
inline constexpr int kMin3DSize = 2;
inline constexpr int kMax3DSize = 256;

struct Lut1D {
  int size = 0;
  std::vector<float> rgb;  // size * 3: entry i is (r, g, b)
  Domain domain;
  static Lut1D identity(int size);
  friend bool operator==(const Lut1D&, const Lut1D&) = default;
};

struct Lut3D {
  int size = 0;
  std::vector<float> rgb;  // size^3 * 3, red fastest: entry (r, g, b) at ((b*N + g)*N + r) * 3
  Domain domain;
  static Lut3D identity(int size);
  std::size_t index(int r, int g, int b) const {
    return ((static_cast<std::size_t>(b) * size + g) * size + r) * 3;
  }
  friend bool operator==(const Lut3D&, const Lut3D&) = default;
};

// A parsed .cube file. With both tables, the 1D one is a shaper applied first (Resolve).
struct CubeFile {
  std::string title;
  std::vector<std::string> comments;  // '#' lines before the data, without the '#'
  std::optional<Lut1D> lut1d;
  std::optional<Lut3D> lut3d;
  friend bool operator==(const CubeFile&, const CubeFile&) = default;
};

// Strict parser: every problem is an error "NAME:LINE: what is wrong" with code
// "cube.syntax" (malformed line), "cube.size" (size out of range or entry count wrong),
// "cube.domain" (min >= max), "cube.value" (non-finite entry). `name` labels messages.
Result<CubeFile> parse_cube(std::string_view text, std::string_view name = "cube");
// `files`: where the path is opened (encode/io/beneath.hpp; default: as given, a FIFO refused).
Result<CubeFile> read_cube(const std::filesystem::path& path, const io::InputFiles& files = {});
// Writes with 9 significant digits, so float tables round-trip exactly.
Result<std::string> format_cube(const CubeFile& cube);
Result<void> write_cube(const CubeFile& cube, const std::filesystem::path& path);

// Reference evaluation of one colour (OCIO's formulas, float arithmetic).
Rgb eval(const Lut1D& lut, Rgb in);
Rgb eval(const Lut3D& lut, Rgb in, Interpolation interp);
Rgb eval(const CubeFile& cube, Rgb in, Interpolation interp);

// ---- Shapers (encode/grade/shaper.cpp) ------------------------------------------------------
// Scene-referred relative values (1.0 = diffuse white) into [0,1] LUT input and back.
//   pq:        s = PQ_inv(x * 100 cd/m2), i.e. 1.0 = 100 nits as OCIO's "linear nits/100";
//              covers x in [0, 100]
//   log2:      s = (log2((x + x0) / 0.18) - lo) / (hi - lo), x0 = 0.18 * 2^lo so 0 -> 0;
//              lo/hi in stops around mid grey (default -12, +9: x up to ~92)
//   sqrt:      s = sqrt(x / max), sqrt_sqrt: s = (x / max)^(1/4), max default 100
//   none:      s = x (display placement shapes with PQ of absolute nits instead)
// Outside the covered range the forward shaper clamps to [0,1].
struct ShaperSpec {
  grade::Shaper kind = grade::Shaper::pq;
  double min = 0;    // log2: lowest stop; otherwise 0
  double max = 100;  // log2: highest stop; pq: input mapped to PQ 1.0 (10000 cd/m2); sqrt*: input mapped to 1
  static ShaperSpec defaults(grade::Shaper kind);
  friend bool operator==(const ShaperSpec&, const ShaperSpec&) = default;
};
inline constexpr double kPqShaperWhiteNits = 100.0;
double shape(const ShaperSpec& s, double x);
double unshape(const ShaperSpec& s, double signal);
// "pq", "log2", "log2:-12:9", "sqrt", "sqrt:16", "sqrt-sqrt", "none"
Result<ShaperSpec> parse_shaper_spec(std::string_view text);
std::string to_string(const ShaperSpec& s);
// The comment line hdrd writes into .cube files it produces, and reads back.
std::string shaper_comment(const ShaperSpec& s);
std::optional<ShaperSpec> shaper_from_comments(const std::vector<std::string>& comments);

namespace detail {
// A log-spaced table (see ShaperTable) for the SIMD buffer kernel: out = f(x * scale) on
// channels R, G, B of RGBA pixels; at_one above u >= 1, linear to at_zero below `lowest`.
struct BitTableArgs {
  const float* values;
  std::uint32_t count;      // entries in values
  std::uint32_t first_key;  // float bits >> shift of `lowest`
  int shift;                // 23 - log2(steps per octave)
  float lowest, at_zero, at_one, scale;
};
void bit_table_rgba(const BitTableArgs& t, float* rgba, std::size_t pixels);
}  // namespace detail

// The shaper for whole buffers in float: PQ through log-spaced tables (exact at the
// knots, linear between; error stated by kShaperTableMaxError and checked by a test),
// the others through float log2/exp2/sqrt.
inline constexpr double kShaperTableMaxError = 1e-6;  // in shaper signal units
class ShaperTable {
 public:
  explicit ShaperTable(const ShaperSpec& spec);
  float forward(float x) const;
  float inverse(float s) const;
  // Channels R, G, B of `pixels` RGBA pixels, in place.
  void forward_rgba(float* rgba, std::size_t pixels) const;
  void inverse_rgba(float* rgba, std::size_t pixels) const;
  const ShaperSpec& spec() const { return spec_; }

 private:
  ShaperSpec spec_;
  // Log-spaced table of f(u), u in [2^kLowExp, 1], kSteps segments per octave.
  struct BitTable {
    int low_exp = 0, steps_log2 = 0;
    std::uint32_t first_key = 0;
    float lowest = 0;  // 2^low_exp
    float at_zero = 0;
    std::vector<float> values;
    float eval(float u, float at_one) const;
    detail::BitTableArgs args(float scale, float at_one) const;
  };
  BitTable fwd_, inv_;
};

// ---- Baking a tone curve into a LUT (encode/grade/grade.cpp) ---------------------------
// A baked LUT maps shaped relative scene values to PQ-encoded display nits (Rec.2020);
// its .cube records what it was baked for in a comment line, and load_grade warns when
// the display peak differs.
struct BakeRecord {
  double peak_nits = 0;
  double paper_white_nits = 0;
  std::string curve;
  std::string apply;
};
std::string bake_comment(const BakeRecord& r);  // "HDRD_BAKED peak_nits=1000 paper_white_nits=203 ..."
std::optional<BakeRecord> bake_record_from_comments(const std::vector<std::string>& comments);

struct BakeRequest {
  std::string curve;                        // tone curve name (tonemap registry)
  tonemap::ParamValues params;
  std::optional<tonemap::Apply> apply;      // empty: the curve's default
  tonemap::Display display;
  ShaperSpec shaper = ShaperSpec::defaults(grade::Shaper::pq);
  int size = 65;
  std::shared_ptr<const grade::Grade> look; // optional scene or display look baked in too
  std::string title;
  int error_samples = 20000;                // random colours for the bake error
};
// Bake error against the analytic pipeline (shaper -> [scene look] -> curve -> [display
// look]) on random shaped colours and a grey ramp, in PQ signal units.
struct BakeError {
  double max_pq = 0, mean_pq = 0;
  double max_code10 = 0;                    // max_pq * 1023
  int samples = 0;
  std::array<double, 3> worst_input{};      // relative scene RGB of the worst sample
};
struct BakeResult {
  CubeFile cube;
  BakeError error;
};
Result<BakeResult> bake_tone_curve(const BakeRequest& request);
// Measures any baked grade (relative scene in, display nits out) against a reference.
BakeError measure_bake_error(const grade::Grade& baked, const ShaperSpec& shaper, int samples,
                             const std::function<std::array<double, 3>(std::array<double, 3>)>& reference_nits);

// ---- Identity strip (encode/grade/lut_png.cpp) ----------------------------------------------
// Selan, "Using Lookup Tables to Accelerate Color Transformations", GPU Gems 2 ch. 24: the
// lattice as N slices of N x N side by side, an N^2 x N image; pixel (x, y) holds lattice
// point (r = x mod N, g = y, b = x div N). Any image editor can then grade it as a picture.
inline constexpr int kMaxStripSize = 128;  // N^2 stays within 16384 pixels
struct Strip {
  int size = 0;
  std::vector<std::uint16_t> rgb;  // N^2 * N pixels, 16-bit R, G, B, rows top-down
};
Strip identity_strip(int size);
Lut3D lut_from_strip(const Strip& strip);  // samples / 65535
// 16-bit RGB PNG with a tEXt chunk "hdrd-lut" holding `text` (size and shaper).
Result<void> write_strip_png(const Strip& strip, const std::filesystem::path& path, const std::string& text);
// Reads 8- or 16-bit RGB(A) PNGs (alpha dropped; an 8-bit file is a warning). `text`
// receives the "hdrd-lut" chunk when the editor kept it.
Result<Strip> read_strip_png(const std::filesystem::path& path, std::string* text, std::vector<std::string>* warnings);
// A colour edit makes the strip a function of each pixel's own colour; a spatial edit
// (blur, sharpen, resize) pulls the pixels at slice edges toward the neighbouring slice,
// whose lattice colour is far away. `pull_*` is the mean move of R at the right (r = N-1)
// and left (r = 0) slice edges toward the neighbour, beyond a linear extrapolation from
// inside the slice; `noise` the mean |second difference| inside slices.
struct SpatialEditCheck {
  double pull_right = 0, pull_left = 0, noise = 0;
  bool suspected = false;
};
SpatialEditCheck detect_spatial_edit(const Lut3D& lut);

// ---- Fast application (encode/grade/lut_apply.cpp) ------------------------------------------
// A 3D table prepared for the SIMD kernel (Highway, dynamic dispatch: SSE4/AVX2/AVX-512
// chosen at run time). Thread-safe to share; apply() splits work over std::threads.
class Applier3D {
 public:
  Applier3D(const Lut3D& lut, Interpolation interp);
  // RGBA float, in place; alpha untouched. threads: 0 = hardware threads, 1 = caller only.
  void apply(float* rgba, std::size_t pixels, int threads = 1) const;
  // RGBA half (IEEE binary16 bits) in, RGBA half out (may alias), alpha copied.
  void apply_half(const std::uint16_t* in, std::uint16_t* out, std::size_t pixels, int threads = 1) const;
  Interpolation interpolation() const { return interp_; }
  int size() const { return size_; }

 private:
  int size_;
  Interpolation interp_;
  std::vector<float> table_;            // RGBX per lattice entry, red fastest
  std::array<float, 3> min_, scale_;    // lattice coordinate = (x - min) * scale
};

// Name of the SIMD target the kernel runs on here ("AVX3", "AVX2", "SSE4", ...).
std::string simd_target_name();


}  // namespace hdrd::lut
