#include "job/frame_job.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <future>

#include <fmt/format.h>

#include "display/displays.hpp"
#include "display/profile.hpp"
#include "encode/grade/grade.hpp"
#include "encode/grade/lut.hpp"
#include "encode/io/io.hpp"
#include "encode/io/stills.hpp"
#include "encode/parallel.hpp"
#include "encode/pipeline.hpp"
#include "job/build.hpp"
#include "patterns/patterns.hpp"
#include "patterns/plot.hpp"
#include "shading/gpu_encode.hpp"
#include "shading/renderer.hpp"
#include "shading/scene_loader.hpp"

namespace hdrd::job {
namespace {

using Clock = std::chrono::steady_clock;
double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }
// The process's CPU time (every thread), for the CPU cost of reading an EXR (OpenEXR's own
// thread pool, which CpuMeter does not see): exact only where nothing else runs beside it.
// Wall time is what the user waits for; encode_cpu is CpuMeter's (this thread and the pool's
// tasks for it, whatever else the process runs: bench/run-sequence.sh).
double process_cpu_ms() {
  timespec t{};
  ::clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

Error cancelled() { return make_error("request.cancelled", "cancelled"); }

struct StillOptions {
  io::AvifOptions avif;
  io::JxlOptions jxl;
  io::JpegOptions jpeg;
  io::GainMapOptions gain_map;
};

io::AvifOptions avif_options(const FrameRequest& r, int threads) {
  io::AvifOptions o;
  if (!r.is_null("quality")) o.quality = static_cast<int>(r.integer("quality"));
  o.lossless = r.boolean("lossless");
  if (!r.is_null("avif.bits")) o.bits = static_cast<int>(r.integer("avif.bits"));
  if (!r.is_null("avif.range")) o.range = parse_range(r.text("avif.range"));
  if (!r.is_null("avif.matrix")) o.matrix = r.text("avif.matrix") == "rgb" ? io::AvifMatrix::rgb : io::AvifMatrix::ycbcr;
  if (!r.is_null("avif.chroma")) {
    const std::string c = r.text("avif.chroma");
    o.chroma = c == "444" ? io::ChromaSubsampling::yuv444
               : c == "422" ? io::ChromaSubsampling::yuv422 : io::ChromaSubsampling::yuv420;
  }
  if (!r.is_null("avif.speed")) o.speed = static_cast<int>(r.integer("avif.speed"));
  o.threads = threads;
  return o;
}

io::JxlOptions jxl_options(const FrameRequest& r, int threads) {
  io::JxlOptions o;
  if (!r.is_null("quality")) o.quality = static_cast<int>(r.integer("quality"));
  o.lossless = r.boolean("lossless");
  o.effort = static_cast<int>(r.integer("jxl.effort"));
  o.threads = threads;
  return o;
}

io::JpegOptions jpeg_options(const FrameRequest& r) {
  io::JpegOptions o;
  if (!r.is_null("quality")) o.quality = static_cast<int>(r.integer("quality"));
  o.subsample_chroma = !r.boolean("jpeg.chroma_444");
  return o;
}

io::GainMapOptions gain_map_options(const FrameRequest& r) {
  io::GainMapOptions o;
  o.primary = jpeg_options(r);
  o.gain_map_quality = static_cast<int>(r.integer("gainmap.quality"));
  o.gain_map_scale = static_cast<int>(r.integer("gainmap.scale"));
  o.channels = r.text("gainmap.channels") == "luminance" ? io::GainMapChannels::luminance : io::GainMapChannels::rgb;
  o.gamma = r.number("gainmap.gamma");
  o.offset_sdr = r.number("gainmap.offset_sdr");
  o.offset_hdr = r.number("gainmap.offset_hdr");
  return o;
}

// The stills' options, read when the job is made so that every setting is checked (and
// used) whatever the outputs; the gain map's only where the source has scene light.
StillOptions still_options(const FrameRequest& r, int threads) {
  StillOptions o{avif_options(r, threads), jxl_options(r, threads), jpeg_options(r), {}};
  if (r.source != Source::pattern) o.gain_map = gain_map_options(r);
  return o;
}


}  // namespace

struct FrameJob::State {
  FrameRequest request;
  std::vector<Output> outputs;
  JobOptions options;
  EncodeInput input;
  DisplayTarget target;
  std::vector<std::string> warnings;
  nlohmann::json timings = nlohmann::json::object();
  bool durable = false;
  // render stage
  std::optional<EncodeSettings> settings;
  std::optional<PreparedPipeline> prepared;
  std::optional<EncodedFrame> gpu_frame;
  std::optional<Image> scene_frame;  // the full scene-referred frame, when read back
  // finish stage: the scene light the CPU encoded (the SDR rendition encodes it again)
  std::optional<io::ExrImage> exr;
  SceneInput cpu_input;
  std::optional<EncodedFrame> sdr_frame;
  StillOptions stills;
  io::PngOptions png;
  nlohmann::json render_info;
  double illuminance_lux = 0;

  bool wants(bool OutputInfo::*need) const {
    return std::any_of(outputs.begin(), outputs.end(), [&](Output o) { return output_info(o).*need; });
  }
  bool stopped() const { return options.should_stop && options.should_stop(); }
};

namespace {

// Every output must have a form for the request's source and the resolved mode.
Result<void> check_outputs(const std::vector<Output>& outputs, Source source, Mode mode) {
  for (Output o : outputs)
    if (!applies(output_info(o), source, mode))
      return make_error("request.value", fmt::format("formats: {} has no {} form", to_string(mode), output_info(o).name),
                        "formats");
  return {};
}

// The encoder settings of the request, keeping what the asked-for outputs need.
Result<EncodeSettings> job_settings(FrameJob::State& st) {
  auto settings = encode_settings(st.request, st.target, st.options.threads, &st.warnings, st.options.resources.get(),
                                  st.options.files);
  if (!settings) return settings.error();
  settings->keep_display_nits = st.wants(&OutputInfo::needs_display_nits);
  settings->png_samples = st.wants(&OutputInfo::needs_signal16);
  return settings;
}

}  // namespace

FrameJob::FrameJob(std::unique_ptr<State> s) : s_(std::move(s)) {}
FrameJob::~FrameJob() = default;

Result<void> FrameJob::set_outputs(std::vector<Output> outputs) {
  if (auto ok = check_outputs(outputs, s_->request.source, s_->target.mode); !ok) return ok.error();
  s_->outputs = std::move(outputs);
  return {};
}

void FrameJob::set_stop(std::function<bool()> should_stop) { s_->options.should_stop = std::move(should_stop); }

bool FrameJob::needs_renderer() const { return s_->request.source == Source::render; }
const DisplayTarget& FrameJob::target() const { return s_->target; }
const FrameRequest& FrameJob::request() const { return s_->request; }
const std::vector<Output>& FrameJob::outputs() const { return s_->outputs; }
const EncodeInput& FrameJob::input() const { return s_->input; }

Result<std::unique_ptr<FrameJob>> FrameJob::create(FrameRequest request, JobOptions options, EncodeInput input,
                                                   std::optional<std::vector<Output>> outputs) {
  auto s = std::make_unique<State>();
  if (request.source == Source::render && request.scene.kind == SceneRef::Kind::builtin &&
      !shading::is_builtin_scene(request.scene.name)) {
    std::string names;
    for (const auto& n : shading::builtin_scene_names()) names += (names.empty() ? "" : ", ") + n;
    return make_error("request.value",
                      fmt::format("scene: no built-in scene '{}' (one of: {}; or a .gltf/.glb/.json file)",
                                  request.scene.name.substr(0, 64), names),
                      "scene");
  }
  auto target = resolve_display(request, &s->warnings, options.files);
  if (!target) return target.error();
  s->target = *target;
  if (!outputs) {
    auto named = outputs_from_names(request.list("formats"), request.source, target->mode);
    if (!named) return named.error();
    outputs = std::move(*named);
  }
  if (auto ok = check_outputs(*outputs, request.source, target->mode); !ok) return ok.error();
  if (request.source == Source::encode && input.path.empty() && input.bytes.empty())
    return make_error("request.value", "an encode request needs an EXR", "image");
  if (request.source == Source::pattern)
    if (auto ok = check_pattern_mode(request, s->target); !ok) return ok.error();
  s->stills = still_options(request, options.threads);
  s->png.level = static_cast<int>(request.integer("png_level"));
  s->png.threads = options.threads;
  s->durable = request.boolean("durable");
  s->request = std::move(request);
  s->outputs = std::move(*outputs);
  s->options = std::move(options);
  s->input = std::move(input);
  return std::unique_ptr<FrameJob>(new FrameJob(std::move(s)));
}

// ---- render stage ----------------------------------------------------------------------

namespace {

// tone.max_frame_average_nits, once the exposure is final (a sequence's decision too).
void limit_frame_average(FrameJob::State& st, const SceneInput& in, PreparedPipeline& p) {
  apply_frame_average_limit(p, in);
  if (p.frame_average_limit && !p.frame_average_limit->not_applied.empty())
    st.warnings.push_back(fmt::format("tone.max_frame_average_nits {:g} is not applied: {}",
                                      p.frame_average_limit->limit_nits, p.frame_average_limit->not_applied));
}

}  // namespace

Result<void> FrameJob::render(shading::Renderer& renderer) {
  State& st = *s_;
  if (!needs_renderer()) return {};
  auto settings = job_settings(st);
  if (!settings) return settings.error();
  if (st.stopped()) return cancelled();

  // Exposure is always metered on the renderer's 8x8 block means (RTR4 §8.2.2 meters a
  // reduced frame), so the exposure never depends on which outputs were asked for.
  shading::RenderRequest rq = render_request(st.request, st.options);
  rq.readback = shading::Readback::reduced;
  const auto t0 = Clock::now();
  auto r = renderer.render(rq);
  if (!r) {
    Error e = r.error();
    // Fields inside an inline scene are reported relative to the request.
    if (st.request.scene.kind == SceneRef::Kind::inline_json && !e.field.empty() && e.field.rfind("scene", 0) != 0)
      e.field = "scene." + e.field;
    return e;
  }
  st.timings["render"] = ms_since(t0);
  for (auto& w : r->warnings) st.warnings.push_back(std::move(w));
  if (st.request.integer("samples") > shading::kMaxSamples)
    st.warnings.push_back(fmt::format("samples: {} asked, the renderer takes at most {}", st.request.integer("samples"),
                                      shading::kMaxSamples));
  st.illuminance_lux = r->dominant_illuminance_lux;
  st.render_info = {{"scene", r->scene_name},
                    {"backend", r->backend},
                    {"gl_renderer", r->gl_renderer},
                    {"gl_version", r->gl_version},
                    {"width", rq.width},
                    {"height", rq.height},
                    {"samples", r->samples},
                    {"render_ms", r->render_ms},
                    {"dominant_illuminance_lux", r->dominant_illuminance_lux},
                    {"triangles", r->triangles},
                    {"environment", r->environment},
                    {"environment_ms", r->environment_ms},
                    {"energy_compensation", rq.energy_compensation},
                    {"time_s", rq.time_s},
                    {"duration_s", r->duration_s}};
  if (r->scene_cut) st.render_info["scene_cut"] = true;
  if (r->exposure_ev100) st.render_info["keyframed_ev100"] = *r->exposure_ev100;
  if (r->exposure_compensation_ev) st.render_info["keyframed_compensation_ev"] = *r->exposure_compensation_ev;

  SceneInput meter;
  meter.image = &r->metering_nits;
  meter.units = InputUnits::absolute;
  if (r->dominant_illuminance_lux > 0) meter.illuminance_lux = r->dominant_illuminance_lux;
  settings->exposure.mode = exposure_mode(st.request);
  // A scene's keyframed exposure (docs/scene-format.md "Keyframes"): its EV100 is the camera
  // exposure where the request leaves the mode to the rule and gives no EV100 of its own;
  // its compensation adds to the request's.
  if (r->exposure_ev100 && st.request.text("exposure.mode") == "auto" && st.request.is_null("exposure.ev100")) {
    settings->exposure.mode = exposure::Mode::camera;
    settings->exposure.ev100 = *r->exposure_ev100;
  }
  if (r->exposure_compensation_ev) settings->exposure.compensation_ev += *r->exposure_compensation_ev;
  auto prepared = prepare_pipeline(meter, *settings);
  if (!prepared) return prepared.error();
  if (st.options.temporal)
    if (auto ok = st.options.temporal(meter, *prepared, {r->scene_cut, r->duration_s}); !ok) return ok.error();
  limit_frame_average(st, meter, *prepared);
  st.settings = std::move(*settings);
  if (st.stopped()) return cancelled();

  // The encoder rule: on the GPU unless asked otherwise, the program cannot do the request,
  // or an output needs the display light only the CPU path keeps (the EXR dump).
  const std::string where = st.request.text("encoder");
  if (where == "gpu" && st.settings->keep_display_nits)
    return make_error("request.conflict",
                      "encoder gpu: the exr output needs the display light only the CPU encoder keeps", "encoder");
  const bool want_gpu = choose_encoder(where, shading::renderer_kind(r->gl_renderer), st.settings->keep_display_nits) ==
                        EncoderChoice::gpu;
  if (want_gpu) {
    const auto t1 = Clock::now();
    auto enc = shading::GpuEncoder::create(renderer, *prepared);
    if (enc) {
      auto f = (*enc)->encode();
      if (!f) return f.error();
      st.gpu_frame = std::move(f->frame);
      st.timings["encode"] = ms_since(t1);
      st.timings["encode_gpu_pass"] = f->gpu_ms;
      st.timings["encode_readback"] = f->readback_ms;
    } else if (where == "gpu") {
      return enc.error();
    } else {
      st.warnings.push_back("encoded on the CPU: " + enc.error().message);
    }
  }
  if (!st.gpu_frame || st.wants(&OutputInfo::needs_scene_frame)) {
    const auto t2 = Clock::now();
    auto full = renderer.read_frame();
    if (!full) return full.error();
    st.scene_frame = std::move(*full);
    st.timings["readback"] = ms_since(t2);
  }
  st.prepared = std::move(*prepared);
  return {};
}

// ---- finish stage ----------------------------------------------------------------------

namespace {

Result<EncodedFrame> finish_render(FrameJob::State& st) {
  if (!st.prepared) return make_error("internal", "a render request finished before it was rendered");
  nlohmann::json render = st.render_info;
  render["encoder"] = st.gpu_frame ? "gpu" : "cpu";
  if (st.scene_frame) {
    st.cpu_input.image = &*st.scene_frame;
    st.cpu_input.units = InputUnits::absolute;
  }
  if (st.gpu_frame) {
    EncodedFrame f = std::move(*st.gpu_frame);
    st.gpu_frame.reset();
    f.settings["render"] = render;
    return f;
  }
  SceneInput& in = st.cpu_input;
  in.image = &*st.scene_frame;
  in.units = InputUnits::absolute;
  const auto t0 = Clock::now();
  auto f = encode_prepared(in, *st.prepared);
  if (!f) return f.error();
  st.timings["encode"] = ms_since(t0);
  f->settings["render"] = render;
  return f;
}

Result<EncodedFrame> finish_encode(FrameJob::State& st) {
  const auto t0 = Clock::now();
  const double c0 = process_cpu_ms();
  // Half files decode straight to half pixels, which the encoder reads as they are.
  const io::ExrReadOptions read{.half_pixels = true};
  const std::span upload(reinterpret_cast<const std::uint8_t*>(st.input.bytes.data()), st.input.bytes.size());
  auto exr = upload.empty() ? io::read_exr(st.input.path, read, st.options.files) : io::read_exr_memory(upload, read);
  if (!exr) return exr.error();
  st.timings["read"] = ms_since(t0);
  // An upload's bytes are not needed once decoded: freed before the encoder's buffers.
  const std::size_t upload_bytes = st.input.bytes.size();
  std::string().swap(st.input.bytes);
  st.timings["read_cpu"] = process_cpu_ms() - c0;
  const CpuMeter encode_cpu;
  for (auto& w : exr->warnings) st.warnings.push_back(std::move(w));
  if (st.stopped()) return cancelled();
  const io::NonFiniteSamples non_finite = io::count_non_finite(*exr);
  if (non_finite.total() > 0)
    st.warnings.push_back(fmt::format("input has {} non-finite R, G, B samples ({} NaN, {} infinite): NaN is encoded "
                                      "as 0 and +-Inf as the brightest light, which the tone curve takes to the peak",
                                      non_finite.total(), non_finite.nan, non_finite.inf));
  st.exr = std::move(*exr);
  SceneInput in;
  if (st.exr->holds_half())
    in.half = &st.exr->half;
  else
    in.image = &st.exr->image;
  in.to_working = st.exr->to_working();
  // REFERENCE.md §1.1: relative unless the file has whiteLuminance or the request says.
  const std::string units = st.request.text("input");
  in.units = units.empty() ? (st.exr->white_luminance ? InputUnits::absolute : InputUnits::relative)
                           : *parse_input_units(units);
  in.white_luminance_nits = st.exr->white_luminance.value_or(1.0);
  if (in.units == InputUnits::absolute && !st.exr->white_luminance)
    st.warnings.push_back("input absolute without whiteLuminance: values are taken as cd/m2");
  auto settings = job_settings(st);  // exposure mode: the rule of encode_settings (job/build.cpp)
  if (!settings) return settings.error();
  const auto t1 = Clock::now();
  auto prepared = prepare_pipeline(in, *settings);
  if (!prepared) return prepared.error();
  if (st.options.temporal)
    if (auto ok = st.options.temporal(in, *prepared, {}); !ok) return ok.error();
  limit_frame_average(st, in, *prepared);
  auto f = encode_prepared(in, *prepared);
  if (!f) return f.error();
  st.timings["encode"] = ms_since(t1);
  st.timings["encode_cpu"] = encode_cpu.ms();
  st.prepared = std::move(*prepared);
  f->settings["input"] = {{"name", st.input.name.empty() ? st.input.path.string() : st.input.name},
                          {"units", to_string(in.units)},
                          {"white_luminance_nits", in.white_luminance_nits},
                          {"channels", st.exr->channels},
                          {"compression", st.exr->compression},
                          {"width", st.exr->width()},
                          {"height", st.exr->height()},
                          {"non_finite_samples", {{"nan", non_finite.nan}, {"inf", non_finite.inf}}}};
  if (upload_bytes > 0) f->settings["input"]["bytes"] = upload_bytes;
  st.cpu_input = in;
  return f;
}

Result<EncodedFrame> finish_pattern(FrameJob::State& st) {
  const auto t0 = Clock::now();
  auto f = patterns::make_pattern(st.request.text("pattern"), st.target, pattern_options(st.request),
                                  st.wants(&OutputInfo::needs_display_nits));
  if (!f) return pattern_error(f.error());
  st.timings["encode"] = ms_since(t0);
  // What the client should know: BT.2111 bars are narrow-range 10-bit whatever the display
  // said; a level above the peak is clipped by the encoder.
  const auto& p = f->settings["pattern"];
  if (f->target.range != st.target.range || f->target.bits != st.target.bits)
    st.warnings.push_back(fmt::format("{} is defined as {}-bit {} range codes: sent that way", st.request.text("pattern"),
                                      f->target.bits, to_string(f->target.range)));
  if (p.contains("note")) st.warnings.push_back(p["note"].get<std::string>());
  return f;
}

// The request with the defaults decided at run time filled in as they were decided: the
// display levels from the resolver, the tone curve's application, the exposure mode.
nlohmann::json resolved_request(const FrameRequest& r, const EncodedFrame& f) {
  nlohmann::json j = r.canonical();
  const DisplayTarget& t = f.target;
  j["display"]["mode"] = to_string(t.mode);
  // The clipping pattern's signal spans PQ's 10000 cd/m2 whatever the display (its frame's
  // target says so); the request's peak is the display's, which its squares default to.
  const auto pattern = f.settings.find("pattern");
  j["display"]["peak_nits"] = pattern != f.settings.end() && pattern->contains("display_peak_nits")
                                  ? (*pattern)["display_peak_nits"].get<double>()
                                  : t.peak_nits;
  j["display"]["black_nits"] = t.black_nits;
  j["display"]["paper_white_nits"] = t.paper_white_nits;
  j["display"]["ui_white_nits"] = t.ui_white_nits;
  j["display"]["sdr_white_nits"] = t.sdr_white_nits;
  j["display"]["range"] = to_string(t.range);
  j["display"]["bits"] = t.bits;
  j["display"]["sdr_curve"] = to_string(t.sdr_curve);
  j["display"]["sdr_content_eotf"] = to_string(t.sdr_content_eotf);
  j["display"]["sdr_inverse_tonemap"] = to_string(t.sdr_inverse_tonemap);
  if (const auto tc = f.settings.find("tone_curve"); tc != f.settings.end() && r.source != Source::pattern)
    j["tone"]["apply"] = tc->value("apply", "");
  if (const auto ex = f.settings.find("exposure"); ex != f.settings.end() && r.source != Source::pattern)
    j["exposure"]["mode"] = ex->value("mode", "");
  if (const auto in = f.settings.find("input"); in != f.settings.end()) j["input"] = in->value("units", "");
  return j;
}

// The SDR rendition of the same frame, the gain-map JPEG's primary image: the scene light
// encoded for sRGB SDR (the mode's REFERENCE.md §1.8 levels, full range, 8-bit) at the
// exposure the HDR frame was metered at, so that the map relates two renditions of one
// exposure (ISO 21496-1 §5). Manual exposure whose scale is the metered one: for manual
// metering scene_scale = unit * gain / paper white (encode/pipeline.cpp).
Result<EncodedFrame> sdr_rendition(const SceneInput& in, const PreparedPipeline& hdr) {
  LevelSettings said;
  said.range = Range::full;
  said.sdr_curve = SdrCurve::srgb;
  said.bits = 8;
  auto t = resolve_target(Mode::sdr, {}, said);
  if (!t) return t.error();
  EncodeSettings s = hdr.settings;
  s.target = *t;
  s.keep_display_nits = false;
  s.png_samples = false;
  const double unit_nits = in.units == InputUnits::absolute ? in.white_luminance_nits : t->paper_white_nits;
  s.exposure = exposure::Settings{};
  s.exposure.mode = exposure::Mode::manual;
  s.exposure.gain = hdr.scene_scale * t->paper_white_nits / unit_nits;
  auto p = prepare_pipeline(in, s);
  if (!p) return p.error();
  return encode_prepared(in, *p);
}

Result<std::vector<std::uint8_t>> output_bytes(Output o, const FrameJob::State& st, const EncodedFrame& frame) {
  switch (o) {
    case Output::png: return io::encode_png(frame, st.png);
    case Output::exr: return io::encode_display_exr(frame);
    case Output::raw: return frame.data;
    case Output::scene_exr: {
      // The scene-referred frame: float32, linear Rec.709, absolute cd/m2 (whiteLuminance 1).
      if (!st.scene_frame) return make_error("internal", "the scene frame was not read back");
      io::ExrWriteOptions ex;
      ex.half = false;
      ex.white_luminance = 1.0;
      ex.attributes["scene"] = st.render_info.value("scene", "");
      ex.attributes["units"] = "cd/m2";
      return io::encode_exr(*st.scene_frame, ex);
    }
    case Output::heatmap: return patterns::frame_heatmap(frame).png();
    case Output::avif: return io::encode_avif(frame, st.stills.avif);
    case Output::jxl: return io::encode_jxl(frame, st.stills.jxl);
    case Output::jpeg: return io::encode_jpeg(frame, st.stills.jpeg);
    case Output::jpeg_gainmap: {
      if (!st.sdr_frame) return make_error("internal", "the SDR rendition was not encoded");
      auto j = io::encode_jpeg_gainmap(*st.sdr_frame, frame, st.stills.gain_map);
      if (!j) return j.error();
      return std::move(j->bytes);
    }
  }
  return make_error("internal", "unknown output");
}

}  // namespace

Result<FrameResult> FrameJob::finish() {
  State& st = *s_;
  if (st.stopped()) return cancelled();
  Result<EncodedFrame> frame = make_error("internal", "no source");
  switch (st.request.source) {
    case Source::render: frame = finish_render(st); break;
    case Source::encode: frame = finish_encode(st); break;
    case Source::pattern: frame = finish_pattern(st); break;
  }
  if (!frame) return frame.error();
  if (st.stopped()) return cancelled();
  if (st.wants(&OutputInfo::needs_sdr_rendition)) {
    if (!st.prepared || (!st.cpu_input.image && !st.cpu_input.half))
      return make_error("internal", "no scene light for the SDR rendition");
    const auto t1 = Clock::now();
    auto sdr = sdr_rendition(st.cpu_input, *st.prepared);
    if (!sdr) return sdr.error();
    st.sdr_frame = std::move(*sdr);
    st.timings["encode_sdr_rendition"] = ms_since(t1);
  }
  FrameResult result;
  result.encoder = frame->settings.contains("render") ? frame->settings["render"].value("encoder", "cpu") : "cpu";
  // Serialise the outputs concurrently (each writer is single-threaded), all before any is
  // returned, so that one that cannot be made fails the whole job.
  const auto t0 = Clock::now();
  std::vector<std::future<Result<std::vector<std::uint8_t>>>> jobs;
  for (Output o : st.outputs)
    jobs.push_back(std::async(std::launch::async, [o, &st, &f = *frame] { return output_bytes(o, st, f); }));
  std::optional<Error> failure;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    auto bytes = jobs[i].get();
    if (!bytes) {
      if (!failure) failure = bytes.error();
      continue;
    }
    result.files.push_back({st.outputs[i], std::move(*bytes)});
  }
  if (failure) return *failure;
  st.timings["outputs"] = ms_since(t0);
  frame->settings["request"] = resolved_request(st.request, *frame);
  result.frame = std::move(*frame);
  result.warnings = st.warnings;
  result.durable = st.durable;
  result.timings_ms = st.timings;
  return result;
}

nlohmann::json FrameResult::sidecar() const {
  nlohmann::json j = io::sidecar_json(frame, {});
  j.erase("files");
  j["warnings"] = warnings;
  return j;
}

Result<FrameResult> run_frame_job(FrameJob& job, shading::Renderer* renderer) {
  if (job.needs_renderer()) {
    std::unique_ptr<shading::Renderer> own;
    if (!renderer) {
      const auto backend = shading::parse_backend(job.request().text("backend").empty() ? "auto"
                                                                                          : job.request().text("backend"));
      auto made = shading::Renderer::create(backend.value_or(shading::Backend::automatic));
      if (!made) return made.error();
      own = std::move(*made);
      renderer = own.get();
    }
    if (auto ok = job.render(*renderer); !ok) return ok.error();
  }
  return job.finish();
}

Result<std::map<std::string, std::string>> write_outputs(const FrameResult& result, const std::filesystem::path& outbase) {
  if (outbase.empty() || !outbase.has_filename())
    return make_error("dump.path", fmt::format("output base '{}' has no file name", outbase.string()), "output");
  std::map<std::string, std::string> paths, names;  // names: relative to the sidecar's directory
  std::vector<io::FileToWrite> files;
  for (const auto& f : result.files) {
    const auto& info = output_info(f.id);
    const std::filesystem::path p = outbase.string() + std::string(info.suffix);
    paths[std::string(info.name)] = p.string();
    names[std::string(info.name)] = p.filename().string();
    files.push_back({p, f.bytes});
  }
  nlohmann::json sidecar = result.sidecar();
  sidecar["files"] = names;
  const std::string text = sidecar.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  const std::filesystem::path sidecar_path = outbase.string() + ".json";
  files.push_back({sidecar_path, std::span(reinterpret_cast<const std::uint8_t*>(text.data()), text.size())});
  if (auto ok = io::write_all_or_nothing(files, {.durable = result.durable}); !ok) return ok.error();
  paths["sidecar"] = sidecar_path.string();
  return paths;
}

EncoderChoice choose_encoder(std::string_view setting, shading::RendererKind kind, bool needs_display_light) {
  if (setting == "gpu") return EncoderChoice::gpu;
  if (setting == "cpu" || needs_display_light) return EncoderChoice::cpu;
  return kind == shading::RendererKind::software ? EncoderChoice::cpu : EncoderChoice::gpu;
}

}  // namespace hdrd::job
