// Raw DRM buffers, JSON sidecars, atomic writes and the all-or-nothing dump of an
// encoded frame (docs/dump-format.md describes every file and key written here).
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <future>
#include <random>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <fmt/format.h>

#include "encode/io/io.hpp"
#include "encode/io/internal.hpp"
#include "encode/colour/transfer.hpp"

namespace hdrd::io {
namespace fs = std::filesystem;

// ---- frame checks -----------------------------------------------------------------------

namespace detail {

int bytes_per_pixel(std::uint32_t drm_fourcc) {
  if (drm_fourcc == kDrmFormatXbgr2101010 || drm_fourcc == kDrmFormatXrgb8888) return 4;
  if (drm_fourcc == kDrmFormatAbgr16161616f) return 8;
  return 0;
}

namespace {
bool fourcc_fits_mode(std::uint32_t fourcc, Mode mode) {
  switch (mode) {
    case Mode::hdr10:
    case Mode::hlg: return fourcc == kDrmFormatXbgr2101010;
    case Mode::scrgb: return fourcc == kDrmFormatAbgr16161616f;
    case Mode::sdr:
    case Mode::sdr_bt1886: return fourcc == kDrmFormatXrgb8888 || fourcc == kDrmFormatXbgr2101010;
  }
  return false;
}
}  // namespace

Result<void> check_frame(const EncodedFrame& f) {
  const auto bad = [](std::string msg) { return make_error("frame.invalid", std::move(msg)); };
  if (auto size = check_image_size(f.width, f.height); !size) return size.error();
  const int bpp = bytes_per_pixel(f.drm_fourcc);
  if (bpp == 0) return bad(fmt::format("unsupported DRM format 0x{:08x}", f.drm_fourcc));
  if (!fourcc_fits_mode(f.drm_fourcc, f.target.mode))
    return bad(fmt::format("DRM format {} does not fit mode {}", fourcc_name(f.drm_fourcc), to_string(f.target.mode)));
  if (f.stride_bytes < static_cast<std::size_t>(f.width) * bpp)
    return bad(fmt::format("stride {} bytes is less than width {} x {} bytes per pixel", f.stride_bytes, f.width, bpp));
  if (f.data.size() != f.stride_bytes * static_cast<std::size_t>(f.height))
    return bad(fmt::format("buffer holds {} bytes, expected stride {} x height {} = {}", f.data.size(), f.stride_bytes,
                           f.height, f.stride_bytes * static_cast<std::size_t>(f.height)));
  if (!f.signal16.empty() && f.signal16.size() != static_cast<std::size_t>(f.width) * f.height * 3)
    return bad(fmt::format("signal16 holds {} samples, expected width x height x 3 = {}", f.signal16.size(),
                           static_cast<std::size_t>(f.width) * f.height * 3));
  return {};
}

}  // namespace detail

// ---- atomic writes ----------------------------------------------------------------------

namespace {

std::string errno_text(int err) { return std::strerror(err); }

// A file written under a temporary name next to its final path; removed unless committed.
class TempFile {
 public:
  TempFile() = default;
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  TempFile(TempFile&& o) noexcept : temp_(std::move(o.temp_)), final_(std::move(o.final_)) { o.temp_.clear(); }
  ~TempFile() { discard(); }

  static Result<TempFile> write(const fs::path& final_path, std::span<const std::uint8_t> bytes, bool durable);
  Result<void> commit();
  void discard() {
    if (!temp_.empty()) ::unlink(temp_.c_str());
    temp_.clear();
  }
  const fs::path& final_path() const { return final_; }

 private:
  fs::path temp_, final_;
};

}  // namespace

Error write_error(const fs::path& path, const std::string& what, int err) {
  if (err == ENOSPC || err == EDQUOT) {
    const fs::path dir = path.has_parent_path() ? path.parent_path() : fs::path(".");
    return make_error("io.no_space", fmt::format("cannot write {}: the file system holding {} is full ({})",
                                                 path.filename().string(), dir.string(), errno_text(err)));
  }
  return make_error("io.write", fmt::format("cannot write {}: {} ({})", path.string(), what, errno_text(err)));
}

namespace {

constexpr std::string_view kTempMarker = ".tmp-";
constexpr std::size_t kTempDigits = 12;

}  // namespace

// Creates "<dir>/.<name>.tmp-<random>" with O_EXCL (mode 0666 less the umask, as a plain
// open would give the final file).
Result<int> create_temp_file(const fs::path& final_path, fs::path& temp) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  const fs::path dir = final_path.has_parent_path() ? final_path.parent_path() : fs::path(".");
  for (int attempt = 0; attempt < 16; ++attempt) {
    temp = dir / fmt::format(".{}{}{:012x}", final_path.filename().string(), kTempMarker, rng() & 0xffffffffffffull);
    const int fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) return fd;
    if (errno != EEXIST) return write_error(final_path, "cannot create a temporary file", errno);
  }
  return write_error(final_path, "cannot create a temporary file", EEXIST);
}

namespace {

Result<TempFile> TempFile::write(const fs::path& final_path, std::span<const std::uint8_t> bytes, bool durable) {
  TempFile t;
  auto fd = create_temp_file(final_path, t.temp_);
  if (!fd) return fd.error();
  t.final_ = final_path;
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(*fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : ENOSPC;
      ::close(*fd);
      return write_error(final_path, "write failed", err);
    }
    done += static_cast<std::size_t>(n);
  }
  // Durable: the data reaches the disk before the rename, so that after a power cut the
  // name holds the old file or the whole new one (a rename can reach the disk first).
  if (durable && ::fsync(*fd) != 0) {
    const int err = errno;
    ::close(*fd);
    return write_error(final_path, "fsync failed", err);
  }
  if (::close(*fd) != 0) return write_error(final_path, "close failed", errno);
  return t;
}

Result<void> TempFile::commit() {
  if (::rename(temp_.c_str(), final_.c_str()) != 0) return write_error(final_, "cannot rename the temporary file", errno);
  temp_.clear();
  return {};
}

fs::path directory_of(const fs::path& p) { return p.has_parent_path() ? p.parent_path() : fs::path("."); }

// Durable: fsync the directories that hold the renamed names, so the renames themselves
// survive a power cut (rename(2) is atomic, not durable).
Result<void> sync_directories(const std::vector<fs::path>& finals) {
  std::vector<fs::path> dirs;
  for (const auto& f : finals)
    if (std::find(dirs.begin(), dirs.end(), directory_of(f)) == dirs.end()) dirs.push_back(directory_of(f));
  for (const auto& d : dirs) {
    const int fd = ::open(d.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return write_error(d, "cannot open the directory to fsync it", errno);
    const int rc = ::fsync(fd), err = errno;
    ::close(fd);
    if (rc != 0) return write_error(d, "fsync of the directory failed", err);
  }
  return {};
}

// Renames every temp file to its final name; if one fails, removes the files already
// renamed (and the destructors remove the rest), so nothing is left half-done.
Result<void> commit_all(std::vector<TempFile>& files, bool durable) {
  std::vector<fs::path> finals;
  for (std::size_t i = 0; i < files.size(); ++i) {
    finals.push_back(files[i].final_path());
    if (auto ok = files[i].commit(); !ok) {
      for (std::size_t j = 0; j < i; ++j) ::unlink(files[j].final_path().c_str());
      return ok.error();
    }
  }
  if (!durable) return {};
  if (auto ok = sync_directories(finals); !ok) {  // not durable: take back what was renamed
    for (const auto& f : finals) ::unlink(f.c_str());
    return ok.error();
  }
  return {};
}

}  // namespace

Result<void> write_all_or_nothing(const std::vector<FileToWrite>& files, const WriteOptions& write) {
  std::vector<TempFile> temps;
  for (const auto& f : files) {
    auto t = TempFile::write(f.path, f.bytes, write.durable);
    if (!t) return t.error();
    temps.push_back(std::move(t.value()));
  }
  return commit_all(temps, write.durable);
}

bool is_atomic_write_temporary(std::string_view name) {
  if (name.size() < 1 + 1 + kTempMarker.size() + kTempDigits || name.front() != '.') return false;
  const std::string_view digits = name.substr(name.size() - kTempDigits);
  if (name.substr(name.size() - kTempDigits - kTempMarker.size(), kTempMarker.size()) != kTempMarker) return false;
  return digits.find_first_not_of("0123456789abcdef") == std::string_view::npos;
}

namespace {
constexpr std::string_view kStagingMarker = ".staging-";
constexpr std::string_view kJournalName = "journal";
}  // namespace

bool is_staging_dir_name(std::string_view name) {
  if (name.size() < 1 + 1 + kStagingMarker.size() + kTempDigits || name.front() != '.') return false;
  const std::string_view digits = name.substr(name.size() - kTempDigits);
  if (name.substr(name.size() - kTempDigits - kStagingMarker.size(), kStagingMarker.size()) != kStagingMarker) return false;
  return digits.find_first_not_of("0123456789abcdef") == std::string_view::npos;
}

Result<fs::path> make_staging_dir(const fs::path& outbase) {
  static thread_local std::mt19937_64 rng{std::random_device{}()};
  const fs::path dir = outbase.has_parent_path() ? outbase.parent_path() : fs::path(".");
  for (int attempt = 0; attempt < 16; ++attempt) {
    const fs::path staging =
        dir / fmt::format(".{}{}{:012x}", outbase.filename().string(), kStagingMarker, rng() & 0xffffffffffffull);
    if (::mkdir(staging.c_str(), 0777) == 0) return staging;
    if (errno != EEXIST) return write_error(staging, "cannot create the staging directory", errno);
  }
  return write_error(outbase, "cannot create the staging directory", EEXIST);
}

Result<void> commit_staged(const fs::path& staging, const std::vector<std::string>& journal,
                           const std::vector<std::pair<fs::path, fs::path>>& moves) {
  std::string text;
  for (const auto& name : journal) text += name + "\n";
  if (auto ok = atomic_write(staging / kJournalName, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()),
                             {.durable = true});
      !ok)
    return ok.error();
  for (const auto& [from, to] : moves)
    if (::rename(from.c_str(), to.c_str()) != 0) return write_error(to, "cannot rename it into place", errno);
  return {};
}

std::size_t sweep_staging(const fs::path& dir) {
  std::size_t removed = 0;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(dir, ec)) {
    if (!is_staging_dir_name(entry.path().filename().string()) || !entry.is_directory(ec) || entry.is_symlink(ec)) continue;
    // The journal names final files beside the staging directory: bare names only.
    auto journal = InputFiles{}.read(entry.path() / kJournalName, std::size_t{64} << 20);
    if (journal) {
      std::size_t start = 0;
      while (start < journal->size()) {
        const std::size_t end = std::min(journal->find('\n', start), journal->size());
        const std::string name = journal->substr(start, end - start);
        start = end + 1;
        if (name.empty() || name == "." || name == ".." || name.find('/') != std::string::npos) continue;
        if (::unlink((dir / name).c_str()) == 0) ++removed;
      }
    }
    for (const auto& staged : fs::directory_iterator(entry.path(), ec))
      removed += staged.path().filename() != kJournalName && staged.is_regular_file(ec) ? 1 : 0;
    fs::remove_all(entry.path(), ec);
  }
  return removed;
}

Result<void> atomic_write(const fs::path& path, std::span<const std::uint8_t> bytes, const WriteOptions& write) {
  auto temp = TempFile::write(path, bytes, write.durable);
  if (!temp) return temp.error();
  std::vector<TempFile> one;
  one.push_back(std::move(temp.value()));
  return commit_all(one, write.durable);
}

// ---- raw --------------------------------------------------------------------------------

Result<void> write_raw(const fs::path& path, const EncodedFrame& frame, const WriteOptions& write) {
  if (auto ok = detail::check_frame(frame); !ok) return ok.error();
  return atomic_write(path, frame.data, write);
}

// ---- sidecar ----------------------------------------------------------------------------

namespace {

nlohmann::json xy(color::Chromaticity c) { return nlohmann::json::array({c.x, c.y}); }

nlohmann::json primaries_json(const color::Primaries& p) {
  return {{"red", xy(p.red)}, {"green", xy(p.green)}, {"blue", xy(p.blue)}, {"white", xy(p.white)}};
}

std::string_view container_name(const DisplayTarget& t) {
  return t.container() == color::kRec2020 ? "rec2020" : "rec709";
}

std::string_view transfer_name(const DisplayTarget& t) {
  switch (t.mode) {
    case Mode::hdr10: return "pq";
    case Mode::hlg: return "hlg";
    case Mode::scrgb: return "linear";
    case Mode::sdr: return t.sdr_curve == SdrCurve::srgb ? "srgb" : "gamma22";
    case Mode::sdr_bt1886: return "bt1886";
  }
  return "?";
}

int bits_of(std::uint32_t fourcc) {
  if (fourcc == kDrmFormatXrgb8888) return 8;
  if (fourcc == kDrmFormatAbgr16161616f) return 16;
  return 10;
}

}  // namespace

nlohmann::json sidecar_json(const EncodedFrame& frame, const std::map<std::string, std::string>& files) {
  const DisplayTarget& t = frame.target;
  const int bpp = detail::bytes_per_pixel(frame.drm_fourcc);
  nlohmann::json j;
  j["format"] = "hdrd-dump";
  j["format_version"] = 1;
#ifdef HDRD_VERSION_STRING
  j["hdrd_version"] = HDRD_VERSION_STRING;
#endif
  j["mode"] = std::string(to_string(t.mode));
  j["fourcc"] = fourcc_name(frame.drm_fourcc);
  j["fourcc_code"] = frame.drm_fourcc;
  j["width"] = frame.width;
  j["height"] = frame.height;
  j["stride_bytes"] = frame.stride_bytes;
  j["bytes_per_pixel"] = bpp;
  j["bits"] = bits_of(frame.drm_fourcc);
  j["range"] = t.mode == Mode::scrgb ? "full" : std::string(to_string(t.range));
  j["container"] = {{"name", container_name(t)}, {"primaries", primaries_json(t.container())}};
  j["transfer"] = std::string(transfer_name(t));
  if (t.mode == Mode::hlg) j["hlg_system_gamma"] = transfer::hlg_system_gamma(t.peak_nits);
  j["peak_nits"] = t.peak_nits;
  j["black_nits"] = t.black_nits;
  j["paper_white_nits"] = t.paper_white_nits;
  j["ui_white_nits"] = t.ui_white_nits;
  j["sdr_white_nits"] = t.sdr_white_nits;
  j["sdr_content_eotf"] = to_string(t.sdr_content_eotf);
  j["sdr_inverse_tonemap"] = to_string(t.sdr_inverse_tonemap);
  j["target_source"] = t.source;
  j["mastering_display"] = {{"primaries", primaries_json(frame.mastering.primaries)},
                            {"max_nits", frame.mastering.max_nits},
                            {"min_nits", frame.mastering.min_nits}};
  // HDR signals carry CTA-861.3 levels (the rule of encode/frame.hpp); SDR frames have none: 0.
  const CarriedLightLevel carried =
      t.is_hdr() ? carried_light_level(frame.content_light, frame.mastering) : CarriedLightLevel{};
  j["content_light_level"] = {{"max_cll_nits", carried.max_cll_nits},
                              {"max_fall_nits", carried.max_fall_nits},
                              {"max_cll_nits_measured", frame.content_light.max_cll_nits},
                              {"max_fall_nits_measured", frame.content_light.max_fall_nits}};
  // The frame's display light as sent (measure_frame_light: maxRGB of the decoded codes):
  // its average (what MaxFALL and a display's ABL see) and distribution. HDR modes only.
  if (t.is_hdr()) {
    const FrameLight light = measure_frame_light(frame);
    nlohmann::json pct = nlohmann::json::object();
    for (double p : kFrameLightPercentiles) pct[fmt::format("{:g}", p)] = light.percentile_nits(p);
    j["frame_light"] = {{"frame_average_nits", light.mean_nits}, {"max_nits", light.max_nits},
                        {"percentiles_nits", pct}};
  }
  j["files"] = files;
  j["settings"] = frame.settings.is_object() ? frame.settings : nlohmann::json::object();
  return j;
}

// ---- dump formats -----------------------------------------------------------------------

std::optional<DumpFormat> parse_dump_format(std::string_view s) {
  if (s == "png") return DumpFormat::png;
  if (s == "exr") return DumpFormat::exr;
  if (s == "raw") return DumpFormat::raw;
  return std::nullopt;
}

std::vector<DumpFormat> default_formats(Mode mode) {
  if (mode == Mode::scrgb) return {DumpFormat::exr, DumpFormat::raw};
  return {DumpFormat::png, DumpFormat::exr, DumpFormat::raw};
}

namespace {

std::string_view extension(DumpFormat f) {
  switch (f) {
    case DumpFormat::png: return "png";
    case DumpFormat::exr: return "exr";
    case DumpFormat::raw: return "raw";
  }
  return "?";
}

// settings values as EXR string attributes: strings as they are, anything else as JSON.
std::map<std::string, std::string> exr_attributes(const EncodedFrame& frame) {
  const DisplayTarget& t = frame.target;
  std::map<std::string, std::string> a;
  a["mode"] = std::string(to_string(t.mode));
  a["peak_nits"] = fmt::format("{}", t.peak_nits);
  a["black_nits"] = fmt::format("{}", t.black_nits);
  a["paper_white_nits"] = fmt::format("{}", t.paper_white_nits);
  if (frame.settings.is_object())
    for (const auto& [key, value] : frame.settings.items())
      a["settings." + key] = value.is_string() ? value.get<std::string>() : value.dump();
  return a;
}

// EXR dump of an encoded frame: display light in the container primaries, scaled so that
// value x whiteLuminance = cd/m2 (scRGB: nits / 80, whiteLuminance 80; otherwise
// nits / paper white, whiteLuminance = paper white).
}  // namespace

Result<std::vector<std::uint8_t>> encode_display_exr(const EncodedFrame& frame) {
  if (!frame.display_nits)
    return make_error("dump.exr", "the EXR dump needs the frame's display light (display_nits), which the encoder did not keep",
                      "format");
  const Image& nits = *frame.display_nits;
  if (nits.width != frame.width || nits.height != frame.height)
    return make_error("dump.exr", fmt::format("display light is {}x{}, the frame is {}x{}", nits.width, nits.height,
                                              frame.width, frame.height));
  const double white = frame.target.mode == Mode::scrgb ? transfer::kScrgbUnitNits : frame.target.paper_white_nits;
  if (!(white > 0)) return make_error("dump.exr", "paper white must be positive for the EXR dump", "paper_white_nits");
  // Scaled and rounded to half in one pass on every core (no float copy of the frame).
  const ImageHalf scaled = to_half(nits, static_cast<float>(1.0 / white));
  ExrWriteOptions options;
  options.half = true;
  options.chromaticities = frame.target.container();
  options.white_luminance = white;
  options.attributes = exr_attributes(frame);
  options.compression = "piz";  // lossless, about twice as fast as zip for 4K half (platform notes §4)
  return encode_exr(scaled, options);
}

namespace {

fs::path with_extension(const fs::path& outbase, std::string_view ext) {
  fs::path p = outbase;
  p += ".";
  p += std::string(ext);
  return p;
}

// A file of the dump: its final path and the temp file holding its bytes until commit.
Result<void> stage(std::vector<TempFile>& temps, const fs::path& path, std::span<const std::uint8_t> bytes,
                   const WriteOptions& write) {
  auto t = TempFile::write(path, bytes, write.durable);
  if (!t) return t.error();
  temps.push_back(std::move(t.value()));
  return {};
}

std::vector<DumpFormat> unique_formats(const EncodedFrame& frame, const std::vector<DumpFormat>& formats) {
  std::vector<DumpFormat> wanted;
  for (DumpFormat f : formats.empty() ? default_formats(frame.target.mode) : formats)
    if (std::find(wanted.begin(), wanted.end(), f) == wanted.end()) wanted.push_back(f);
  return wanted;
}

DumpResult list_files(const fs::path& outbase, const std::vector<DumpFormat>& wanted,
                      const std::vector<ExtraFile>& extra, std::map<std::string, std::string>& names) {
  DumpResult result;  // names: relative to the sidecar's directory
  for (DumpFormat f : wanted) {
    const fs::path p = with_extension(outbase, extension(f));
    result.files[std::string(extension(f))] = p.string();
    names[std::string(extension(f))] = p.filename().string();
  }
  for (const auto& x : extra) {
    const fs::path p = outbase.string() + x.suffix;
    result.files[x.kind] = p.string();
    names[x.kind] = p.filename().string();
  }
  return result;
}

}  // namespace

Result<DumpResult> write_dumps(const EncodedFrame& frame, const fs::path& outbase,
                               const std::vector<DumpFormat>& formats, const std::vector<ExtraFile>& extra,
                               const DumpOptions& options) {
  if (outbase.empty() || !outbase.has_filename())
    return make_error("dump.path", fmt::format("output base '{}' has no file name", outbase.string()), "output");
  if (auto ok = detail::check_frame(frame); !ok) return ok.error();
  if (auto ok = check_png_options(options.png); !ok) return ok.error();
  const std::vector<DumpFormat> wanted = unique_formats(frame, formats);
  const auto wants = [&](DumpFormat f) { return std::find(wanted.begin(), wanted.end(), f) != wanted.end(); };
  if (frame.target.mode == Mode::scrgb && wants(DumpFormat::png))  // before any work or file
    return encode_png(frame, options.png).error();

  // PNG and EXR encode concurrently (each on its own threads) while this thread stages the
  // files that need no encoding (the raw buffer as the frame holds it, the extras). Nothing
  // is renamed into place until every file exists, so a failure leaves nothing behind.
  using Bytes = Result<std::vector<std::uint8_t>>;
  std::optional<std::future<Bytes>> png, exr;
  if (wants(DumpFormat::png))
    png = std::async(std::launch::async, [&] { return encode_png(frame, options.png); });
  if (wants(DumpFormat::exr)) exr = std::async(std::launch::async, [&] { return encode_display_exr(frame); });
  std::vector<TempFile> temps;
  std::optional<Error> failure;
  const auto note = [&](Result<void> r) {
    if (!r && !failure) failure = r.error();
  };
  if (wants(DumpFormat::raw)) note(stage(temps, with_extension(outbase, "raw"), frame.data, options.write));
  for (const auto& x : extra)
    if (!failure) note(stage(temps, outbase.string() + x.suffix, x.bytes, options.write));
  for (auto* job : {&png, &exr}) {
    if (!*job) continue;
    Bytes bytes = (*job)->get();  // always waited for: the tasks read `frame`
    if (!bytes) {
      if (!failure) failure = bytes.error();
      continue;
    }
    if (!failure)
      note(stage(temps, with_extension(outbase, job == &png ? "png" : "exr"), *bytes, options.write));
  }
  if (failure) return *failure;

  std::map<std::string, std::string> names;
  DumpResult result = list_files(outbase, wanted, extra, names);
  const fs::path sidecar_path = with_extension(outbase, "json");
  const std::string sidecar = sidecar_json(frame, names).dump(2) + "\n";
  if (auto ok = stage(temps, sidecar_path,
                      std::span(reinterpret_cast<const std::uint8_t*>(sidecar.data()), sidecar.size()), options.write);
      !ok)
    return ok.error();
  if (auto ok = commit_all(temps, options.write.durable); !ok) return ok.error();
  result.files["sidecar"] = sidecar_path.string();
  return result;
}

}  // namespace hdrd::io
