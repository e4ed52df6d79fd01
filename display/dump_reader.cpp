#include "display/dump_reader.hpp"

#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "display/profile.hpp"
#include "display/scanout.hpp"
#include "encode/io/json_text.hpp"

namespace hdrd::display {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

Error bad(const fs::path& p, const std::string& field, const std::string& msg) {
  return make_error("dump.sidecar", fmt::format("{}: {}", p.string(), msg), field);
}

std::optional<double> number(const json& j, const char* key) {
  if (!j.is_object() || !j.contains(key) || !j[key].is_number()) return std::nullopt;
  const double v = j[key].get<double>();
  return std::isfinite(v) ? std::optional<double>(v) : std::nullopt;
}

Result<std::uint32_t> read_fourcc(const json& j, const fs::path& p) {
  if (j.contains("fourcc_code") && j["fourcc_code"].is_number_unsigned()) return j["fourcc_code"].get<std::uint32_t>();
  if (j.contains("fourcc") && j["fourcc"].is_string() && j["fourcc"].get<std::string>().size() == 4) {
    const std::string s = j["fourcc"].get<std::string>();
    return fourcc(s[0], s[1], s[2], s[3]);
  }
  return bad(p, "fourcc", "no 'fourcc' (4 characters) or 'fourcc_code'");
}

Result<int> read_dimension(const json& j, const char* key, const fs::path& p) {
  if (!j.contains(key) || !j[key].is_number_integer() || j[key].get<std::int64_t>() <= 0 ||
      j[key].get<std::int64_t>() > kMaxImageDimension)
    return bad(p, key, fmt::format("'{}' must be an integer in 1..{}", key, kMaxImageDimension));
  return static_cast<int>(j[key].get<std::int64_t>());
}

std::optional<color::Primaries> read_primaries(const json& j) {
  if (!j.is_object()) return std::nullopt;
  color::Primaries p;
  const std::pair<const char*, color::Chromaticity*> parts[] = {
      {"red", &p.red}, {"green", &p.green}, {"blue", &p.blue}, {"white", &p.white}};
  for (const auto& [k, dst] : parts) {
    if (!j.contains(k) || !j[k].is_array() || j[k].size() != 2 || !j[k][0].is_number() || !j[k][1].is_number())
      return std::nullopt;
    *dst = {j[k][0].get<double>(), j[k][1].get<double>()};
  }
  return p;
}

void read_levels(const json& j, EncodedFrame& f) {
  if (auto v = number(j, "peak_nits")) f.target.peak_nits = *v;
  if (auto v = number(j, "black_nits")) f.target.black_nits = *v;
  if (auto v = number(j, "paper_white_nits")) f.target.paper_white_nits = *v;
  f.mastering = f.target.mastering();
  if (const json& md = j.value("mastering_display", json()); md.is_object()) {
    if (auto p = read_primaries(md.value("primaries", json()))) f.mastering.primaries = *p;
    if (auto v = number(md, "max_nits")) f.mastering.max_nits = *v;
    if (auto v = number(md, "min_nits")) f.mastering.min_nits = *v;
  }
  if (const json& cl = j.value("content_light_level", json()); cl.is_object()) {
    f.content_light.max_cll_nits = number(cl, "max_cll_nits_measured").value_or(number(cl, "max_cll_nits").value_or(0));
    f.content_light.max_fall_nits = number(cl, "max_fall_nits_measured").value_or(number(cl, "max_fall_nits").value_or(0));
  }
}

fs::path raw_path(const json& j, const fs::path& sidecar) {
  if (const json& files = j.value("files", json()); files.is_object() && files.contains("raw") && files["raw"].is_string()) {
    fs::path r = files["raw"].get<std::string>();
    return r.is_absolute() ? r : sidecar.parent_path() / r;
  }
  fs::path r = sidecar;
  r.replace_extension(".raw");
  return r;
}

}  // namespace

Result<DumpHeader> read_dump_header(const fs::path& sidecar) {
  auto text = read_binary_file(sidecar, 16 << 20);
  if (!text) return text.error();
  auto parsed = io::parse_json_bounded(std::string_view(reinterpret_cast<const char*>(text->data()), text->size()),
                                       io::JsonBounds{16u << 20, 64, "sidecar", "dump.json_"});
  if (!parsed) return bad(sidecar, "", "not a JSON object: " + parsed.error().message);
  const json& j = *parsed;
  if (!j.is_object()) return bad(sidecar, "", "not a JSON object (is this a dump's .json sidecar?)");
  const auto mode = parse_mode(j.value("mode", ""));
  if (!mode) return bad(sidecar, "mode", "no valid 'mode' (hdr10, hlg, scrgb, sdr, sdr-bt1886)");
  EncodedFrame f;
  f.target = default_target(*mode);
  auto fcc = read_fourcc(j, sidecar);
  if (!fcc) return fcc.error();
  f.drm_fourcc = *fcc;
  if (f.drm_fourcc == kDrmFormatXbgr2101010 && (*mode == Mode::sdr || *mode == Mode::sdr_bt1886)) f.target.bits = 10;
  auto w = read_dimension(j, "width", sidecar);
  if (!w) return w.error();
  auto h = read_dimension(j, "height", sidecar);
  if (!h) return h.error();
  f.width = *w;
  f.height = *h;
  const int bpp = scanout_bytes_per_pixel(f.drm_fourcc);
  if (!bpp) return bad(sidecar, "fourcc", fmt::format("fourcc {} is not a scan-out format", fourcc_name(f.drm_fourcc)));
  f.stride_bytes = static_cast<std::size_t>(f.width) * bpp;
  if (j.contains("stride_bytes")) {
    if (!j["stride_bytes"].is_number_unsigned()) return bad(sidecar, "stride_bytes", "'stride_bytes' must be a number");
    f.stride_bytes = j["stride_bytes"].get<std::size_t>();
  }
  if (const auto r = parse_range(j.value("range", "full")); r) f.target.range = *r;
  else return bad(sidecar, "range", "'range' must be full or narrow");
  read_levels(j, f);
  if (auto c = check_image_size(f.width, f.height); !c) return c.error();
  const fs::path raw = raw_path(j, sidecar);
  const std::size_t need = f.stride_bytes * static_cast<std::size_t>(f.height);
  std::error_code ec;
  const auto size = fs::file_size(raw, ec);
  if (ec) return make_error("dump.raw", fmt::format("cannot read {}: {}", raw.string(), ec.message()), "raw");
  if (size != need)
    return make_error("dump.raw", fmt::format("{} is {} bytes; the sidecar's {}x{} at stride {} needs {}", raw.string(),
                                              size, f.width, f.height, f.stride_bytes, need), "raw");
  return DumpHeader{std::move(f), raw};
}

Result<EncodedFrame> read_dump(const fs::path& sidecar) {
  auto header = read_dump_header(sidecar);
  if (!header) return header.error();
  EncodedFrame& f = header->frame;
  auto data = read_binary_file(header->raw, f.stride_bytes * static_cast<std::size_t>(f.height));
  if (!data) return data.error();
  f.data = std::move(*data);
  if (auto c = check_frame(f); !c) return c.error();
  return std::move(f);
}

}  // namespace hdrd::display
