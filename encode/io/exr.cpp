// OpenEXR read and write (OpenEXR 3.1, generic MultiPartInputFile + FrameBuffer so any
// channel set, compression, tiling and data window works). Every OpenEXR exception is
// caught here and turned into one Error naming the file and the problem.
#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <thread>

#include <sys/mman.h>

#include <fmt/format.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfChromaticitiesAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfIO.h>
#include <OpenEXR/ImfInputPart.h>
#include <OpenEXR/ImfMultiPartInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfPartType.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <OpenEXR/ImfStandardAttributes.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfThreading.h>
#include <OpenEXR/Iex.h>
#include <Imath/half.h>

#include "encode/io/io.hpp"
#include "encode/parallel.hpp"

namespace hdrd::io {
namespace fs = std::filesystem;

namespace {

// OpenEXR's global thread pool starts at 0 threads; give it the machine's cores once.
// The header size limits are a second line behind prescan_header(): OpenEXR then rejects
// absurd data windows and tile sizes itself while parsing the header (process-wide
// settings; hdrd never handles larger images anyway).
int exr_threads() {
  static const int threads = [] {
    Imf::Header::setMaxImageSize(kMaxImageDimension, kMaxImageDimension);
    Imf::Header::setMaxTileSize(kMaxImageDimension, kMaxImageDimension);
    if (Imf::globalThreadCount() == 0)
      Imf::setGlobalThreadCount(std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, 8));
    return Imf::globalThreadCount();
  }();
  return threads;
}

// An Imf::IStream over bytes in memory (daemon uploads, fuzzing). Reads past the end
// throw Iex::InputExc, as Imf::StdIFStream does at end of file.
class MemoryIStream final : public Imf::IStream {
 public:
  MemoryIStream(std::span<const std::uint8_t> bytes, const std::string& name)
      : Imf::IStream(name.c_str()), bytes_(bytes) {}
  bool isMemoryMapped() const override { return true; }
  char* readMemoryMapped(int n) override {
    const char* p = take(n);
    return const_cast<char*>(p);  // OpenEXR only reads through it
  }
  bool read(char c[], int n) override {
    const char* p = take(n);
    if (n > 0) std::memcpy(c, p, static_cast<std::size_t>(n));
    return pos_ < bytes_.size();
  }
  std::uint64_t tellg() override { return pos_; }
  void seekg(std::uint64_t pos) override { pos_ = pos; }

 private:
  const char* take(int n) {
    if (n < 0 || pos_ > bytes_.size() || static_cast<std::uint64_t>(n) > bytes_.size() - pos_)
      throw Iex::InputExc("Unexpected end of file.");
    const char* p = reinterpret_cast<const char*>(bytes_.data()) + pos_;
    pos_ += static_cast<std::uint64_t>(n);
    return p;
  }
  std::span<const std::uint8_t> bytes_;
  std::uint64_t pos_ = 0;
};

constexpr std::array<std::uint8_t, 4> kExrMagic{0x76, 0x2f, 0x31, 0x01};

constexpr std::array<std::pair<std::string_view, Imf::Compression>, 10> kCompressions{{
    {"none", Imf::NO_COMPRESSION},
    {"rle", Imf::RLE_COMPRESSION},
    {"zips", Imf::ZIPS_COMPRESSION},
    {"zip", Imf::ZIP_COMPRESSION},
    {"piz", Imf::PIZ_COMPRESSION},
    {"pxr24", Imf::PXR24_COMPRESSION},
    {"b44", Imf::B44_COMPRESSION},
    {"b44a", Imf::B44A_COMPRESSION},
    {"dwaa", Imf::DWAA_COMPRESSION},
    {"dwab", Imf::DWAB_COMPRESSION},
}};

std::string compression_name(Imf::Compression c) {
  for (const auto& [name, value] : kCompressions)
    if (value == c) return std::string(name);
  return fmt::format("unknown({})", static_cast<int>(c));
}

std::optional<Imf::Compression> parse_compression(std::string_view s) {
  for (const auto& [name, value] : kCompressions)
    if (name == s) return value;
  return std::nullopt;
}

// OpenEXR messages may span lines; an Error message is one line.
std::string one_line(std::string s) {
  std::replace_if(s.begin(), s.end(), [](char c) { return c == '\n' || c == '\r'; }, ' ');
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

bool contains_nocase(std::string_view hay, std::string_view needle) {
  auto it = std::search(hay.begin(), hay.end(), needle.begin(), needle.end(), [](char a, char b) {
    return std::tolower(static_cast<unsigned char>(a)) == std::tolower(static_cast<unsigned char>(b));
  });
  return it != hay.end();
}

Error exr_error(const std::string& name, std::string code, const std::string& problem) {
  return make_error(std::move(code), fmt::format("cannot read EXR {}: {}", name, one_line(problem)));
}

// ---- metadata -------------------------------------------------------------------------

bool near(double a, double b, double tol) { return std::abs(a - b) <= tol; }
bool near(color::Chromaticity a, color::Chromaticity b, double tol) {
  return near(a.x, b.x, tol) && near(a.y, b.y, tol);
}

// The attribute is float32: snap it to the exact published set it stands for, so that
// equal whites compare equal and no spurious Bradford adaptation is applied.
color::Primaries snap_primaries(color::Primaries p) {
  constexpr double kTol = 2e-6;  // float32 holds these to ~3e-8
  for (const auto& s : color::spaces()) {
    const auto& q = s.primaries;
    if (s.space != color::Space::xyz && near(p.red, q.red, kTol) && near(p.green, q.green, kTol) &&
        near(p.blue, q.blue, kTol) && near(p.white, q.white, kTol))
      return q;
  }
  for (auto w : {color::kD65, color::kDciWhite, color::kAcesWhite, color::kIlluminantE})
    if (near(p.white, w, kTol)) p.white = w;
  return p;
}

// OpenEXR TN "Chromaticities": CIE XYZ data is flagged by primaries R(1,0) G(0,1) B(0,0).
bool is_xyz_chromaticities(const color::Primaries& p) {
  constexpr double kTol = 1e-6;
  return near(p.red, {1, 0}, kTol) && near(p.green, {0, 1}, kTol) && near(p.blue, {0, 0}, kTol);
}

// Usable when the conversion to_working() will build from it is finite (a white with
// y = 0, collinear primaries or a white whose Bradford cone response is 0 are not).
bool usable_primaries(const color::Primaries& p) {
  try {
    const color::Mat3 m = color::rgb_to_rgb(p, color::kRec2020);
    for (const auto& row : m.m)
      for (double v : row)
        if (!std::isfinite(v)) return false;
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

void read_colour_metadata(const Imf::Header& h, ExrImage& out) {
  if (Imf::hasChromaticities(h)) {
    const Imf::Chromaticities& c = Imf::chromaticities(h);
    const color::Primaries p{{c.red.x, c.red.y}, {c.green.x, c.green.y}, {c.blue.x, c.blue.y},
                             {c.white.x, c.white.y}};
    if (is_xyz_chromaticities(p)) {
      out.chromaticities = p;
      out.is_xyz = true;
    } else if (usable_primaries(p)) {
      out.chromaticities = snap_primaries(p);
    } else {
      out.warnings.push_back("ignoring degenerate chromaticities attribute; assuming Rec.709");
    }
  }
  if (Imf::hasWhiteLuminance(h)) {
    const double wl = Imf::whiteLuminance(h);
    if (std::isfinite(wl) && wl > 0) out.white_luminance = wl;
    else out.warnings.push_back(fmt::format("ignoring whiteLuminance {} (not a positive number)", wl));
  }
}

void read_other_metadata(const Imf::Header& h, ExrImage& out) {
  for (auto it = h.channels().begin(); it != h.channels().end(); ++it) out.channels.emplace_back(it.name());
  out.compression = compression_name(h.compression());
  for (auto it = h.begin(); it != h.end(); ++it)
    if (const auto* s = dynamic_cast<const Imf::StringAttribute*>(&it.attribute()))
      out.attributes[it.name()] = s->value();
  const auto dw = h.dataWindow(), dp = h.displayWindow();
  if (dw != dp)
    out.warnings.push_back(fmt::format(
        "data window ({},{})-({},{}) differs from display window ({},{})-({},{}); using the data window",
        dw.min.x, dw.min.y, dw.max.x, dw.max.y, dp.min.x, dp.min.y, dp.max.x, dp.max.y));
}

// ---- channel selection ----------------------------------------------------------------

struct ChannelPlan {
  enum class Kind { rgb, grey, luma_chroma } kind = Kind::rgb;
  std::string layer;                   // "" for the default layer, else "name" (channels "name.R")
  std::array<std::string, 3> rgb;      // channels read into R, G, B ("" = filled with 0)
  std::string grey;                    // Kind::grey: the channel replicated into R, G, B
  std::string alpha;                   // "" = A is 1
};

std::string prefixed(const std::string& layer, const char* name) {
  return layer.empty() ? std::string(name) : layer + "." + name;
}

bool layer_has_colour(const Imf::ChannelList& list, const std::string& layer) {
  for (const char* n : {"R", "G", "B", "Y"})
    if (list.findChannel(prefixed(layer, n))) return true;
  return false;
}

std::string describe_channels(const Imf::ChannelList& list) {
  std::string s;
  for (auto it = list.begin(); it != list.end(); ++it) s += (s.empty() ? "" : ", ") + std::string(it.name());
  return s.empty() ? "none" : s;
}

// Rule (docs/dump-format.md "Reading EXR"): R,G,B(+A) of the default layer, else of the
// first layer (alphabetically) that has them; Y (+RY/BY chroma) as luminance; a file with
// exactly one channel is grey whatever its name; partial RGB is filled with 0.
Result<ChannelPlan> plan_channels(const Imf::ChannelList& list, const std::string& name,
                                  std::vector<std::string>& warnings) {
  ChannelPlan plan;
  std::size_t count = 0;
  for (auto it = list.begin(); it != list.end(); ++it) ++count;
  if (count == 1) {
    plan.kind = ChannelPlan::Kind::grey;
    plan.grey = list.begin().name();
    if (plan.grey != "Y")
      warnings.push_back(fmt::format("single channel '{}' replicated to grey R=G=B", plan.grey));
    return plan;
  }
  if (!layer_has_colour(list, "")) {
    std::set<std::string> layers;
    list.layers(layers);
    auto it = std::find_if(layers.begin(), layers.end(),
                           [&](const std::string& l) { return layer_has_colour(list, l); });
    if (it == layers.end())
      return exr_error(name, "exr.channels",
                       fmt::format("no usable channels (has: {}; expected R,G,B, Y, or a single channel)",
                                   describe_channels(list)));
    plan.layer = *it;
    warnings.push_back(fmt::format("no R,G,B or Y in the default layer; using layer '{}'", plan.layer));
  }
  const auto has = [&](const char* n) { return list.findChannel(prefixed(plan.layer, n)) != nullptr; };
  if (has("A")) plan.alpha = prefixed(plan.layer, "A");
  if (!has("R") && !has("G") && !has("B")) {
    plan.kind = (has("RY") || has("BY")) ? ChannelPlan::Kind::luma_chroma : ChannelPlan::Kind::grey;
    plan.grey = prefixed(plan.layer, "Y");
    return plan;
  }
  std::string missing;
  const char* names[3] = {"R", "G", "B"};
  for (int i = 0; i < 3; ++i) {
    if (has(names[i])) plan.rgb[static_cast<std::size_t>(i)] = prefixed(plan.layer, names[i]);
    else missing += (missing.empty() ? "" : ",") + std::string(names[i]);
  }
  if (!missing.empty()) warnings.push_back(fmt::format("channel(s) {} missing; filled with 0", missing));
  return plan;
}

Result<void> check_sampling(const Imf::ChannelList& list, const ChannelPlan& plan, const std::string& name) {
  if (plan.kind == ChannelPlan::Kind::luma_chroma) return {};  // RgbaInputFile reconstructs chroma
  for (const std::string& c : {plan.rgb[0], plan.rgb[1], plan.rgb[2], plan.grey, plan.alpha}) {
    if (c.empty()) continue;
    const Imf::Channel* ch = list.findChannel(c);
    if (ch && (ch->xSampling != 1 || ch->ySampling != 1))
      return exr_error(name, "exr.channels",
                       fmt::format("channel '{}' is subsampled ({}x{}); only full-resolution channels are supported",
                                   c, ch->xSampling, ch->ySampling));
  }
  return {};
}

// ---- pixel reading ---------------------------------------------------------------------

// Transparent huge pages for a frame-sized buffer not yet touched (Linux's THP mode is
// usually "madvise"): a 4K float frame is 32 000 page faults in 4 KiB pages, 64 in 2 MiB
// ones. Only the 2 MiB-aligned interior can use them; a refusal changes nothing.
void advise_huge_pages(void* p, std::size_t bytes) {
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  const auto begin = (reinterpret_cast<std::uintptr_t>(p) + kHuge - 1) & ~(kHuge - 1);
  const auto end = (reinterpret_cast<std::uintptr_t>(p) + bytes) & ~(kHuge - 1);
  if (end > begin) ::madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE);
}

// A channel name the file does not have: OpenEXR fills such a slice with its fill value
// (in its worker threads, while it decodes the rest).
std::string absent_channel(const Imf::ChannelList& list, std::string name) {
  while (list.findChannel(name)) name += "_";
  return name;
}

// Reads in bands of scan lines into storage reserved up front but zero-filled band by band,
// so a file that declares a large image and then breaks costs memory only for what it
// really decoded (found by tests/fuzz/exr_fuzz: 500-byte files declaring 1 GiB images).
// Pixels is Image (float samples) or ImageHalf (half samples, read as stored).
template <typename Pixels>
void read_planned(Imf::MultiPartInputFile& file, int part_index, const ChannelPlan& plan, Pixels& img) {
  using Sample = typename decltype(img.rgba)::value_type;
  constexpr Imf::PixelType kType = sizeof(Sample) == 2 ? Imf::HALF : Imf::FLOAT;
  constexpr int kBandLines = 256;  // 8-16 chunks of the common compressions: keeps threads busy
  const Imf::Header& header = file.header(part_index);
  const Imath::Box2i dw = header.dataWindow();
  const std::size_t row_samples = 4 * static_cast<std::size_t>(img.width);
  img.rgba.clear();
  img.rgba.reserve(row_samples * static_cast<std::size_t>(img.height));
  char* base = reinterpret_cast<char*>(img.rgba.data());  // stable: capacity is reserved
  advise_huge_pages(base, img.rgba.capacity() * sizeof(Sample));
  const std::size_t xs = 4 * sizeof(Sample), ys = xs * static_cast<std::size_t>(img.width);
  Imf::FrameBuffer fb;
  const auto add = [&](const std::string& channel, int slot, double fill) {
    if (!channel.empty())
      fb.insert(channel, Imf::Slice::Make(kType, base + slot * sizeof(Sample), dw, xs, ys, 1, 1, fill));
  };
  if (plan.kind == ChannelPlan::Kind::grey) add(plan.grey, 0, 0.0);
  else for (int i = 0; i < 3; ++i) add(plan.rgb[static_cast<std::size_t>(i)], i, 0.0);  // missing: the zero fill
  add(plan.alpha.empty() ? absent_channel(header.channels(), "A") : plan.alpha, 3, 1.0);
  Imf::InputPart part(file, part_index);
  part.setFrameBuffer(fb);
  for (int y0 = dw.min.y; y0 <= dw.max.y; y0 += kBandLines) {
    const int y1 = std::min(dw.max.y, y0 + kBandLines - 1);
    img.rgba.resize(row_samples * static_cast<std::size_t>(y1 - dw.min.y + 1));
    part.readPixels(y0, y1);
  }
  if (plan.kind == ChannelPlan::Kind::grey)
    for (std::size_t i = 0, n = img.pixel_count(); i < n; ++i) {
      Sample* p = img.rgba.data() + i * 4;
      p[1] = p[2] = p[0];
    }
}

// Whether every channel the plan reads is stored as half (then it can be read as it is).
bool plan_is_half(const Imf::ChannelList& list, const ChannelPlan& plan) {
  std::vector<std::string> used{plan.grey, plan.alpha, plan.rgb[0], plan.rgb[1], plan.rgb[2]};
  if (plan.kind == ChannelPlan::Kind::luma_chroma)
    used = {prefixed(plan.layer, "Y"), prefixed(plan.layer, "RY"), prefixed(plan.layer, "BY"), plan.alpha};
  for (const std::string& c : used) {
    if (c.empty()) continue;
    const Imf::Channel* ch = list.findChannel(c);
    if (ch && ch->type != Imf::HALF) return false;
  }
  return true;
}

// Luminance/chroma (Y, RY, BY) images: OpenEXR's RgbaInputFile owns the reconstruction
// (chroma upsampling and the Y/RY/BY -> RGB matrix from the file's chromaticities).
void read_luma_chroma(Imf::IStream& stream, const ChannelPlan& plan, const Imath::Box2i& dw, ExrImage& out,
                      bool keep_half) {
  stream.seekg(0);
  stream.clear();
  Imf::RgbaInputFile in(stream, plan.layer, exr_threads());
  const int w = out.image.width, h = out.image.height;
  // Imf::Rgba is four halves, ImageHalf's pixel layout: half output needs no conversion.
  static_assert(sizeof(Imf::Rgba) == 4 * sizeof(std::uint16_t));
  ImageHalf px(w, h);
  // Slice::Make's trick: offset the base so that the data window's origin lands on px[0].
  const std::intptr_t offset =
      (static_cast<std::intptr_t>(dw.min.x) + static_cast<std::intptr_t>(dw.min.y) * w) *
      static_cast<std::intptr_t>(sizeof(Imf::Rgba));
  in.setFrameBuffer(reinterpret_cast<Imf::Rgba*>(reinterpret_cast<std::intptr_t>(px.rgba.data()) - offset), 1,
                    static_cast<std::size_t>(w));
  in.readPixels(dw.min.y, dw.max.y);
  const std::uint16_t one = half(1.0f).bits();
  if (plan.alpha.empty())
    for (std::size_t i = 0; i < px.pixel_count(); ++i) px.rgba[i * 4 + 3] = one;
  if (keep_half) {
    out.half = std::move(px);
    out.image = Image();
    return;
  }
  out.image.rgba.resize(px.rgba.size());
  for (std::size_t i = 0; i < px.rgba.size(); ++i) {
    half v;
    v.setBits(px.rgba[i]);
    out.image.rgba[i] = v;
  }
}

int first_image_part(const Imf::MultiPartInputFile& file) {
  for (int i = 0; i < file.parts(); ++i) {
    const Imf::Header& h = file.header(i);
    if (!h.hasType() || !Imf::isDeepData(h.type())) return i;
  }
  return -1;
}

Result<ExrImage> read_stream(Imf::IStream& stream, const std::string& name, const ExrReadOptions& options) {
  ExrImage out;
  ChannelPlan plan;
  Imath::Box2i dw;
  bool keep_half = false;
  {
    Imf::MultiPartInputFile file(stream, exr_threads());
    const int part = first_image_part(file);
    if (part < 0) return exr_error(name, "exr.unsupported", "the file has only deep-data parts");
    const Imf::Header& h = file.header(part);
    if (file.parts() > 1)
      out.warnings.push_back(fmt::format("multi-part file ({} parts); reading part {}", file.parts(), part));
    dw = h.dataWindow();
    const std::int64_t w = std::int64_t{dw.max.x} - dw.min.x + 1, ht = std::int64_t{dw.max.y} - dw.min.y + 1;
    if (auto size = check_image_size(w, ht); !size) return exr_error(name, "exr.size", size.error().message);
    read_colour_metadata(h, out);
    read_other_metadata(h, out);
    auto planned = plan_channels(h.channels(), name, out.warnings);
    if (!planned) return planned.error();
    plan = std::move(planned.value());
    if (auto s = check_sampling(h.channels(), plan, name); !s) return s.error();
    out.image.width = static_cast<int>(w);
    out.image.height = static_cast<int>(ht);
    keep_half = options.half_pixels && plan_is_half(h.channels(), plan);
    if (plan.kind != ChannelPlan::Kind::luma_chroma) {
      if (!keep_half) {
        read_planned(file, part, plan, out.image);
        return out;
      }
      out.half.width = out.image.width;
      out.half.height = out.image.height;
      out.image = Image();
      read_planned(file, part, plan, out.half);
      return out;
    }
    if (part != 0) return exr_error(name, "exr.unsupported", "luminance/chroma images are read only from part 0");
  }
  read_luma_chroma(stream, plan, dw, out, keep_half);
  return out;
}

Result<ExrImage> read_guarded(Imf::IStream& stream, const std::string& name, const ExrReadOptions& options) {
  try {
    return read_stream(stream, name, options);
  } catch (const std::bad_alloc&) {
    return exr_error(name, "exr.corrupt", "out of memory while decoding (corrupt sizes?)");
  } catch (const std::exception& e) {
    const std::string what = e.what();
    if (contains_nocase(what, "exceeds the maximum"))  // Header::setMaxImageSize, see exr_threads()
      return exr_error(name, "exr.size", fmt::format("image too large ({})", what));
    const bool truncated = contains_nocase(what, "end of file") || contains_nocase(what, "premature");
    return exr_error(name, truncated ? "exr.truncated" : "exr.corrupt",
                     fmt::format("{} ({})", truncated ? "truncated file" : "corrupt file", what));
  } catch (...) {
    return exr_error(name, "exr.corrupt", "corrupt file (unknown exception from OpenEXR)");
  }
}

}  // namespace

color::Mat3 ExrImage::to_working() const {
  // REFERENCE.md §1.1: XYZ is taken as D65-referred and never adapted; other RGB
  // spaces are Bradford-adapted to D65 when their white differs (color::rgb_to_rgb).
  if (is_xyz) return color::xyz_to_rgb(color::kRec2020);
  return color::rgb_to_rgb(chromaticities.value_or(color::kRec709), color::kRec2020);
}

namespace {

// ---- header pre-scan -------------------------------------------------------------------
// OpenEXR 3.1.5 allocates what a header declares before it checks the file holds it: an
// attribute's size (a 60-byte file claiming a 1.8 GB attribute makes it allocate 1.8 GB),
// and chunk offset tables sized from the data window and tile size (1x1 tiles over
// 16384 x 8192 pixels: 1 GiB). Found by tests/fuzz/exr_fuzz. So the header is walked here
// first (OpenEXR file layout: magic, version, then per part "name\0type\0" + i32 size +
// value attributes ending in a 0 byte), and every declared size is checked against the
// bytes actually present, and the data window against check_image_size, before OpenEXR
// sees the file.

class ByteReader {
 public:
  explicit ByteReader(std::span<const std::uint8_t> b) : b_(b) {}
  std::size_t pos() const { return pos_; }
  std::size_t left() const { return b_.size() - pos_; }
  bool at_end() const { return pos_ >= b_.size(); }
  std::uint8_t peek() const { return b_[pos_]; }
  const char* here() const { return reinterpret_cast<const char*>(b_.data() + pos_); }
  void skip(std::size_t n) { pos_ += n; }
  // A 0-terminated string of at most max_len characters; nullopt when it runs past the end.
  std::optional<std::string> cstring(std::size_t max_len) {
    std::size_t end = pos_;
    while (end < b_.size() && b_[end] != 0 && end - pos_ < max_len) ++end;
    if (end >= b_.size() || b_[end] != 0) return std::nullopt;
    std::string s(reinterpret_cast<const char*>(b_.data()) + pos_, end - pos_);
    pos_ = end + 1;
    return s;
  }
  std::int32_t i32_at(std::size_t at) const {
    std::uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | b_[at + static_cast<std::size_t>(i)];
    return static_cast<std::int32_t>(v);
  }

 private:
  std::span<const std::uint8_t> b_;
  std::size_t pos_ = 0;
};

struct PartShape {
  std::optional<std::array<std::int32_t, 4>> data_window;  // xmin, ymin, xmax, ymax
  std::optional<std::array<std::int32_t, 2>> tile_size;
  int compression = -1;
  std::optional<std::int32_t> chunk_count;  // multi-part files state it
  bool tiled = false;
};

// Scan lines per chunk for each compression (OpenEXR's ImfCompression.h numbering).
std::int64_t lines_per_chunk(int compression) {
  constexpr int kLines[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
  return compression >= 0 && compression < 10 ? kLines[compression] : 256;
}

// Lower bound of the chunk count (level 0 only for mip/rip maps; OpenEXR allocates at most
// ~4x that), so requiring 8 bytes of offset table per chunk never rejects a valid file.
std::int64_t min_chunks(const PartShape& p, std::int64_t w, std::int64_t h) {
  if (p.chunk_count) return *p.chunk_count;
  if (p.tiled && p.tile_size) {
    const std::int64_t tx = (*p.tile_size)[0], ty = (*p.tile_size)[1];
    if (tx <= 0 || ty <= 0) return 0;  // OpenEXR rejects it
    return ((w + tx - 1) / tx) * ((h + ty - 1) / ty);
  }
  return (h + lines_per_chunk(p.compression) - 1) / lines_per_chunk(p.compression);
}

void note_attribute(const std::string& attr, const std::string& type, const ByteReader& r, std::int32_t size,
                    PartShape& part) {
  const std::size_t v = r.pos();
  if (attr == "dataWindow" && type == "box2i" && size == 16)
    part.data_window = std::array<std::int32_t, 4>{r.i32_at(v), r.i32_at(v + 4), r.i32_at(v + 8), r.i32_at(v + 12)};
  else if (attr == "tiles" && type == "tiledesc" && size == 9)
    part.tile_size = std::array<std::int32_t, 2>{r.i32_at(v), r.i32_at(v + 4)};
  else if (attr == "compression" && type == "compression" && size == 1)
    part.compression = r.peek();
  else if (attr == "chunkCount" && type == "int" && size == 4)
    part.chunk_count = r.i32_at(v);
  else if (attr == "type" && type == "string")
    part.tiled = std::string_view(r.here(), static_cast<std::size_t>(size)).find("tile") != std::string_view::npos;
}

// Walks one header's attributes; returns an error text, or "" when the header is sound.
std::string scan_attributes(ByteReader& r, std::size_t max_name, PartShape& part) {
  while (true) {
    if (r.at_end()) return "truncated header";
    if (r.peek() == 0) {
      r.skip(1);
      return "";
    }
    const auto attr = r.cstring(max_name);
    const auto type = attr ? r.cstring(max_name) : std::nullopt;
    if (!attr || !type || r.left() < 4) return "truncated or malformed header attribute";
    const std::int32_t size = r.i32_at(r.pos());
    r.skip(4);
    if (size < 0 || static_cast<std::size_t>(size) > r.left())
      return fmt::format("attribute '{}' claims {} bytes but only {} remain in the file", *attr, size, r.left());
    note_attribute(*attr, *type, r, size, part);
    r.skip(static_cast<std::size_t>(size));
  }
}

// Returns the pixel count of the largest part (what a read may decode).
Result<std::int64_t> prescan_header(std::span<const std::uint8_t> bytes, const std::string& name,
                                    ExrSize* largest_size = nullptr) {
  if (bytes.size() < 8) return exr_error(name, "exr.truncated", "truncated file (no version field)");
  ByteReader r(bytes);
  const std::int32_t version = r.i32_at(4);
  const bool multipart = version & 0x1000, long_names = version & 0x400;
  r.skip(8);
  std::vector<PartShape> parts;
  do {
    PartShape part;
    part.tiled = !multipart && (version & 0x200);
    if (auto problem = scan_attributes(r, long_names ? 255 : 31, part); !problem.empty())
      return exr_error(name, problem.find("truncated") == 0 ? "exr.truncated" : "exr.corrupt", problem);
    parts.push_back(part);
  } while (multipart && !r.at_end() && r.peek() != 0 && parts.size() < 1024);
  if (multipart && !r.at_end()) r.skip(1);  // the empty header that ends the list
  std::int64_t chunks = 0, largest = 0;
  for (const PartShape& p : parts) {
    if (!p.data_window) continue;  // OpenEXR reports the missing attribute
    const auto& d = *p.data_window;
    const std::int64_t w = std::int64_t{d[2]} - d[0] + 1, h = std::int64_t{d[3]} - d[1] + 1;
    if (auto size = check_image_size(w, h); !size) return exr_error(name, "exr.size", size.error().message);
    chunks += std::max<std::int64_t>(min_chunks(p, w, h), 0);
    if (w * h > largest && largest_size) *largest_size = {static_cast<int>(w), static_cast<int>(h)};
    largest = std::max(largest, w * h);
  }
  if (chunks > static_cast<std::int64_t>(r.left() / 8))
    return exr_error(name, "exr.truncated",
                     fmt::format("truncated file (the header needs {} chunk offsets, {} bytes remain)", chunks, r.left()));
  return largest;
}

Result<ExrImage> read_exr_bytes(std::span<const std::uint8_t> bytes, const std::string& name,
                                const ExrReadOptions& options) {
  if (bytes.size() < 4 || std::memcmp(bytes.data(), kExrMagic.data(), 4) != 0)
    return exr_error(name, "exr.not_exr", "not an OpenEXR file (no EXR magic number)");
  if (auto ok = prescan_header(bytes, name); !ok) return ok.error();
  exr_threads();
  MemoryIStream stream(bytes, name);
  return read_guarded(stream, name, options);
}

}  // namespace

NonFiniteSamples count_non_finite(const ExrImage& image) {
  // On the bits: an all-ones exponent is Inf (zero mantissa) or NaN. Branch-free, so the
  // loops vectorise.
  NonFiniteSamples n;
  if (image.holds_half()) {
    const std::uint16_t* p = image.half.rgba.data();
    for (std::size_t i = 0, e = image.half.rgba.size(); i < e; ++i) {
      const unsigned m = (i & 3) == 3 ? 0u : p[i] & 0x7fffu;  // alpha is not encoded
      n.nan += m > 0x7c00u;
      n.inf += m == 0x7c00u;
    }
    return n;
  }
  const float* p = image.image.rgba.data();
  for (std::size_t i = 0, e = image.image.rgba.size(); i < e; ++i) {
    std::uint32_t b;
    std::memcpy(&b, p + i, 4);
    const std::uint32_t m = (i & 3) == 3 ? 0u : b & 0x7fffffffu;
    n.nan += m > 0x7f800000u;
    n.inf += m == 0x7f800000u;
  }
  return n;
}

// The whole file is read into memory first: the header pre-scan needs the file size and
// the compressed file is small next to the decoded float image.
Result<ExrImage> read_exr(const fs::path& path, const ExrReadOptions& options, const InputFiles& files) {
  const std::string name = path.string();
  auto fd = files.open(path);
  if (!fd) return reader_error(fd.error(), "exr.missing", "exr.unreadable");
  auto bytes = read_all(fd->get(), name, std::size_t{4} << 30);
  if (!bytes && bytes.error().code == "file.too_large") return exr_error(name, "exr.size", "file is larger than the limit of 4 GiB");
  if (!bytes) return reader_error(bytes.error(), "exr.missing", "exr.unreadable");
  return read_exr_bytes({reinterpret_cast<const std::uint8_t*>(bytes->data()), bytes->size()}, name, options);
}

Result<ExrImage> read_exr_memory(std::span<const std::uint8_t> bytes, const ExrReadOptions& options) {
  return read_exr_bytes(bytes, "<memory>", options);
}

Result<ExrImage> read_exr_memory(std::span<const std::uint8_t> bytes, const ExrReadOptions& options, const std::string& name) {
  return read_exr_bytes(bytes, name, options);
}

Result<std::int64_t> exr_declared_pixels(std::span<const std::uint8_t> bytes) {
  if (bytes.size() < 4 || std::memcmp(bytes.data(), kExrMagic.data(), 4) != 0)
    return exr_error("<memory>", "exr.not_exr", "not an OpenEXR file (no EXR magic number)");
  return prescan_header(bytes, "<memory>");
}

Result<ExrSize> exr_declared_size(std::span<const std::uint8_t> bytes, const std::string& name) {
  if (bytes.size() < 4 || std::memcmp(bytes.data(), kExrMagic.data(), 4) != 0)
    return exr_error(name, "exr.not_exr", "not an OpenEXR file (no EXR magic number)");
  ExrSize size;
  auto ok = prescan_header(bytes, name, &size);
  if (!ok) return ok.error();
  if (size.width <= 0) return exr_error(name, "exr.corrupt", "no data window");
  return size;
}

// ---- writing ---------------------------------------------------------------------------

namespace {

Imf::Chromaticities to_imf(const color::Primaries& p) {
  const auto v = [](color::Chromaticity c) { return Imath::V2f(static_cast<float>(c.x), static_cast<float>(c.y)); };
  return Imf::Chromaticities(v(p.red), v(p.green), v(p.blue), v(p.white));
}

// Whether some alpha differs from 1 (a missing A reads back as 1, so A is written only then).
bool has_alpha(const ImageHalf& image) {
  const std::uint16_t one = half(1.0f).bits();
  for (std::size_t i = 3; i < image.rgba.size(); i += 4)
    if (image.rgba[i] != one) return true;
  return false;
}
bool has_alpha(const Image& image) {
  for (std::size_t i = 3; i < image.rgba.size(); i += 4)
    if (image.rgba[i] != 1.0f) return true;
  return false;
}

Imf::Header make_header(int width, int height, const ExrWriteOptions& options, Imf::Compression compression,
                        bool alpha) {
  Imf::Header h(width, height);
  h.compression() = compression;
  const Imf::PixelType type = options.half ? Imf::HALF : Imf::FLOAT;
  for (const char* c : {"R", "G", "B", "A"})
    if (c[0] != 'A' || alpha) h.channels().insert(c, Imf::Channel(type));
  Imf::addChromaticities(
      h, options.xyz ? Imf::Chromaticities({1, 0}, {0, 1}, {0, 0}, {1.0f / 3, 1.0f / 3}) : to_imf(options.chromaticities));
  if (options.white_luminance) Imf::addWhiteLuminance(h, static_cast<float>(*options.white_luminance));
  for (const auto& [key, value] : options.attributes) h.insert("hdrd:" + key, Imf::StringAttribute(value));
  return h;
}

// An Imf::OStream into a byte vector: the file is built where it is returned, with no
// std::string in between (Imf::StdOSStream's str() and the copy out of it were two copies).
// OpenEXR seeks back to write the chunk offset table, so writes land at the position.
class VectorOStream final : public Imf::OStream {
 public:
  explicit VectorOStream(std::vector<std::uint8_t>& out) : Imf::OStream("<memory>"), out_(out) {}
  void write(const char c[], int n) override {
    const auto count = static_cast<std::size_t>(n);
    if (pos_ + count > out_.size()) out_.resize(pos_ + count);
    std::memcpy(out_.data() + pos_, c, count);
    pos_ += count;
  }
  std::uint64_t tellp() override { return pos_; }
  void seekp(std::uint64_t pos) override { pos_ = pos; }

 private:
  std::vector<std::uint8_t>& out_;
  std::uint64_t pos_ = 0;
};

Result<Imf::Compression> compression_of(const ExrWriteOptions& options) {
  const auto compression = parse_compression(options.compression);
  if (!compression)
    return make_error("exr.write",
                      fmt::format("unknown EXR compression '{}' (none, rle, zips, zip, piz, pxr24, b44, b44a, dwaa, dwab)",
                                  options.compression),
                      "compression");
  return *compression;
}

// Writes interleaved RGBA samples (half or float, as options.half says) with OpenEXR's
// thread pool compressing the chunks.
Result<std::vector<std::uint8_t>> write_samples(int width, int height, const char* base, bool alpha,
                                                const ExrWriteOptions& options) {
  auto compression = compression_of(options);
  if (!compression) return compression.error();
  try {
    const Imf::Header header = make_header(width, height, options, *compression, alpha);
    std::vector<std::uint8_t> bytes;
    bytes.reserve(static_cast<std::size_t>(width) * height * (options.half ? 6 : 12) / 2 + 4096);
    VectorOStream stream(bytes);
    {
      Imf::OutputFile out(stream, header, exr_threads());
      const std::size_t sample = options.half ? sizeof(half) : sizeof(float);
      const std::size_t xs = 4 * sample, ys = xs * static_cast<std::size_t>(width);
      Imf::FrameBuffer fb;
      const char* names[4] = {"R", "G", "B", "A"};
      for (int c = 0; c < (alpha ? 4 : 3); ++c)
        fb.insert(names[c], Imf::Slice(options.half ? Imf::HALF : Imf::FLOAT, const_cast<char*>(base) + c * sample, xs, ys));
      out.setFrameBuffer(fb);
      out.writePixels(height);
    }  // the destructor writes the offset table
    return bytes;
  } catch (const std::exception& e) {
    return make_error("exr.write", fmt::format("cannot encode EXR: {}", one_line(e.what())));
  }
}

template <typename Pixels>
Result<void> check_pixels(const Pixels& image) {
  if (auto size = check_image_size(image.width, image.height); !size) return size.error();
  if (image.rgba.size() != image.pixel_count() * 4)
    return make_error("exr.write", fmt::format("image buffer holds {} samples, expected {} for {}x{} RGBA",
                                               image.rgba.size(), image.pixel_count() * 4, image.width, image.height));
  return {};
}

}  // namespace

ImageHalf to_half(const Image& image, float rgb_scale, int threads) {
  ImageHalf out(image.width, image.height);
  const std::size_t n = image.pixel_count();
  parallel_for(n, threads, 65536, [&](std::size_t begin, std::size_t end) {
    const float* in = image.rgba.data();
    std::uint16_t* o = out.rgba.data();
    for (std::size_t i = begin * 4; i < end * 4; i += 4) {
      // The same float product, then Imath's rounding: bit-identical to scaling first.
      for (int c = 0; c < 3; ++c) o[i + c] = half(in[i + c] * rgb_scale).bits();
      o[i + 3] = half(in[i + 3]).bits();
    }
  });
  return out;
}

Result<std::vector<std::uint8_t>> encode_exr(const Image& image, const ExrWriteOptions& options) {
  if (auto ok = check_pixels(image); !ok) return ok.error();
  if (auto c = compression_of(options); !c) return c.error();
  exr_threads();
  const bool alpha = has_alpha(image);
  if (!options.half)
    return write_samples(image.width, image.height, reinterpret_cast<const char*>(image.rgba.data()), alpha, options);
  // OpenEXR does not convert float to half on output: round here (nearest even, overflow to +-Inf).
  ImageHalf halves;
  try {
    halves = to_half(image);
  } catch (const std::exception& e) {
    return make_error("exr.write", fmt::format("cannot encode EXR: {}", one_line(e.what())));
  }
  return write_samples(image.width, image.height, reinterpret_cast<const char*>(halves.rgba.data()), alpha, options);
}

Result<std::vector<std::uint8_t>> encode_exr(const ImageHalf& image, const ExrWriteOptions& options) {
  if (auto ok = check_pixels(image); !ok) return ok.error();
  if (!options.half)
    return make_error("exr.write", "half pixels are written as half channels (ExrWriteOptions::half)", "half");
  exr_threads();
  return write_samples(image.width, image.height, reinterpret_cast<const char*>(image.rgba.data()), has_alpha(image),
                       options);
}

Result<void> write_exr(const fs::path& path, const Image& image, const ExrWriteOptions& options,
                       const WriteOptions& write) {
  auto bytes = encode_exr(image, options);
  if (!bytes) return bytes.error();
  return atomic_write(path, *bytes, write);
}

Result<void> write_exr(const fs::path& path, const ImageHalf& image, const ExrWriteOptions& options,
                       const WriteOptions& write) {
  auto bytes = encode_exr(image, options);
  if (!bytes) return bytes.error();
  return atomic_write(path, *bytes, write);
}

}  // namespace hdrd::io
