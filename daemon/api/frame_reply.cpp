#include "daemon/api/frame_reply.hpp"

#include <cmath>

#include <fmt/format.h>

namespace hdrd::daemon {
namespace {

std::string header_value(const nlohmann::json& v) {
  if (v.is_string()) return v.get<std::string>();
  if (v.is_number_float()) return fmt::format("{:.6g}", v.get<double>());
  return v.dump();
}

// CTA-861.3 carries whole cd/m2: round up so the metadata never understates the content.
long long ceil_nits(double nits) { return nits > 0 ? static_cast<long long>(std::ceil(nits - 1e-9)) : 0; }

}  // namespace

std::vector<std::pair<std::string, std::string>> frame_headers(const job::FrameResult& result) {
  const EncodedFrame& f = result.frame;
  std::vector<std::pair<std::string, std::string>> h;
  const nlohmann::json& request = f.settings.contains("request") ? f.settings["request"] : nlohmann::json::object();
  for (const auto& s : job::settings()) {
    if (s.header.empty()) continue;
    std::string p(s.path);
    std::replace(p.begin(), p.end(), '.', '/');
    const nlohmann::json::json_pointer ptr("/" + p);
    if (request.contains(ptr) && !request[ptr].is_null()) h.emplace_back(std::string(s.header), header_value(request[ptr]));
  }
  const auto& m = f.mastering;
  h.emplace_back("X-Hdrd-Fourcc", fourcc_name(f.drm_fourcc));
  h.emplace_back("X-Hdrd-Width", std::to_string(f.width));
  h.emplace_back("X-Hdrd-Height", std::to_string(f.height));
  h.emplace_back("X-Hdrd-Stride", std::to_string(f.stride_bytes));
  h.emplace_back("X-Hdrd-MaxCLL", std::to_string(ceil_nits(f.content_light.max_cll_nits)));
  h.emplace_back("X-Hdrd-MaxFALL", std::to_string(ceil_nits(f.content_light.max_fall_nits)));
  h.emplace_back("X-Hdrd-Mastering",
                 fmt::format("R{:.4f},{:.4f} G{:.4f},{:.4f} B{:.4f},{:.4f} W{:.4f},{:.4f} L{:.6g},{:.6g}",
                             m.primaries.red.x, m.primaries.red.y, m.primaries.green.x, m.primaries.green.y,
                             m.primaries.blue.x, m.primaries.blue.y, m.primaries.white.x, m.primaries.white.y, m.max_nits,
                             m.min_nits));
  h.emplace_back("X-Hdrd-Target-Source", f.target.source);
  h.emplace_back("X-Hdrd-Encoder", result.encoder);
  if (f.settings.contains("render")) {
    const auto& r = f.settings["render"];
    h.emplace_back("X-Hdrd-Scene", r.value("scene", ""));
    h.emplace_back("X-Hdrd-Backend", r.value("backend", ""));
  }
  if (f.settings.contains("pattern")) h.emplace_back("X-Hdrd-Pattern", f.settings["pattern"].value("name", ""));
  for (const char* stage : {"render", "encode"})
    if (result.timings_ms.contains(stage))
      h.emplace_back(fmt::format("X-Hdrd-{}-Ms", stage[0] == 'r' ? "Render" : "Encode"),
                     fmt::format("{:.1f}", result.timings_ms[stage].get<double>()));
  for (std::size_t i = 0; i < result.warnings.size() && i < 8; ++i)
    h.emplace_back("X-Hdrd-Warning", one_line(result.warnings[i].substr(0, 200)));
  return h;
}

Result<Reply> frame_reply(job::FrameResult& result, job::Output output) {
  for (auto& file : result.files) {
    if (file.id != output) continue;
    Reply r;
    r.content_type = std::string(job::output_info(output).content_type);
    r.headers = frame_headers(result);
    r.bytes = std::make_shared<const std::vector<std::uint8_t>>(std::move(file.bytes));
    return r;
  }
  return make_error("internal", fmt::format("the job did not make its {} output", job::output_info(output).name));
}

Result<Reply> dump_reply(const job::FrameResult& result, const std::filesystem::path& dump_dir, const std::string& name) {
  auto files = job::write_outputs(result, dump_dir / name);
  if (!files) {
    Error e = files.error();
    if (e.code.rfind("io.", 0) != 0) e.code = "io." + e.code;
    return e;
  }
  nlohmann::json j = result.sidecar();
  j["files"] = *files;
  Reply r = Reply::json(200, j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  r.headers = frame_headers(result);
  return r;
}

}  // namespace hdrd::daemon
