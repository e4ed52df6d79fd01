// hdrd contact-sheet INPUT.exr -o sheet.png: one image through every tone curve (or, with
// --layout gamut-maps, every gamut map) as an SDR preview, labelled, side by side (as RTR4
// fig. 8.15 compares four tone mappers).
#include <filesystem>

#include "encode/io/io.hpp"
#include "encode/pipeline.hpp"
#include "encode/tone/tonemap.hpp"
#include "job/build.hpp"
#include "patterns/plot.hpp"
#include "tools/common/settings_cli.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

struct SheetOptions {
  CommonOptions common;
  SettingArgs args;
  std::string input, output;
  int tile_width = 320;
  int columns = 4;
  std::string layout = "curves";  // or "gamut-maps"
};

void run(const SheetOptions& o) {
  set_progress_enabled(!o.common.quiet);
  // An encode request spelt with the usual flags, whose settings apply to every tile.
  auto doc = request_json(o.args);
  if (!doc) throw HdrdError(doc.error());
  if (!doc->contains("display") || !(*doc)["display"].contains("mode")) (*doc)["display"]["mode"] = "sdr";  // an SDR preview
  job::ParseContext ctx;
  ctx.source = job::Source::encode;
  ctx.spelling = job::Spelling::cli;
  ctx.reach = job::Reach::cli;
  ctx.resolve_path = [](std::string_view p, const std::string&) -> Result<std::filesystem::path> { return std::filesystem::path(p); };
  auto request = job::parse_request_json(*doc, ctx);
  if (!request) throw HdrdError(request.error());
  std::vector<std::string> notes;
  auto target = job::resolve_display(*request, &notes);
  if (!target) throw HdrdError(target.error());
  if (!target->is_sdr())
    throw CliError("contact sheets are SDR previews: use --mode sdr or sdr-bt1886 (--peak sets the tone curves' display)");
  target->bits = 8;
  auto settings = job::encode_settings(*request, *target, static_cast<int>(request->integer("threads")), &notes);
  if (!settings) throw HdrdError(settings.error());
  settings->exposure.mode = job::exposure_mode(*request);
  const EncodeSettings base = *settings;
  const bool gamut_maps = o.layout == "gamut-maps";
  if (!gamut_maps && request->has("tone.curve")) notes.push_back("--tonemap is ignored: the sheet shows every curve");
  if (gamut_maps && request->has("gamut")) notes.push_back("--gamut is ignored: the sheet shows every gamut map");
  auto exr = io::read_exr(o.input);
  if (!exr) throw HdrdError(exr.error());
  const Image small = patterns::downscale(exr->image, o.tile_width);
  SceneInput in;
  in.image = &small;
  in.to_working = exr->to_working();
  in.units = exr->white_luminance ? InputUnits::absolute : InputUnits::relative;
  in.white_luminance_nits = exr->white_luminance.value_or(1.0);

  // One tile per curve, or per gamut map (the alias "desaturate" is ictcp's tile).
  std::vector<std::pair<std::string, EncodeSettings>> runs;
  if (gamut_maps) {
    for (std::string_view name : kGamutMappingNames) {
      const auto g = parse_gamut_mapping(name);
      if (!g || to_string(*g) != name) continue;
      runs.emplace_back(std::string(name), base);
      runs.back().second.gamut = *g;
    }
  } else {
    for (const auto& info : tonemap::curves()) {
      runs.emplace_back(std::string(info.name), base);
      runs.back().second.tone.curve = std::string(info.name);
    }
  }
  std::vector<EncodedFrame> frames;
  std::vector<patterns::SheetTile> tiles;
  frames.reserve(runs.size());
  for (const auto& [label, s] : runs) {
    auto f = encode_frame(in, s);
    if (f) {
      frames.push_back(std::move(*f));
      tiles.push_back({label, nullptr, {}});
    } else {
      tiles.push_back({label, nullptr, f.error().message});
      notes.push_back(label + ": " + f.error().message);
    }
  }
  for (std::size_t i = 0, k = 0; i < tiles.size(); ++i)
    if (tiles[i].error.empty()) tiles[i].frame = &frames[k++];
  const auto title = fmt::format("{}  EXPOSURE {:+g} EV, SDR {:g} CD/M2", std::filesystem::path(o.input).filename().string(),
                                 base.exposure.compensation_ev, base.target.peak_nits);
  auto png = patterns::contact_sheet(tiles, title, o.columns).png();
  if (!png) throw HdrdError(png.error());
  if (auto ok = io::atomic_write(o.output, *png); !ok) throw HdrdError(ok.error());
  const char* what = gamut_maps ? "gamut_maps" : "curves";
  nlohmann::json j = {{"output", o.output}, {what, nlohmann::json::array()}, {"notes", notes}};
  for (const auto& t : tiles) j[what].push_back(t.label);
  print_out(o.common.json ? j.dump(2)
                          : fmt::format("wrote {} ({} {})\n", o.output, tiles.size(), gamut_maps ? "gamut maps" : "curves"));
}

void setup(CLI::App& root) {
  auto o = std::make_shared<SheetOptions>();
  auto* app = root.add_subcommand("contact-sheet", "One EXR through every tone curve, labelled, as an SDR preview PNG");
  app->add_option("input", o->input, "Input OpenEXR")->required();
  app->add_option("-o,--output", o->output, "Output PNG")->required();
  app->add_option("--tile-width", o->tile_width, "Width of each tile (default 320)");
  app->add_option("--columns", o->columns, "Tiles per row (default 4)");
  app->add_option("--layout", o->layout, "curves: one tile per tone curve (default); gamut-maps: one per gamut map, "
                                         "with the request's curve")
      ->check(CLI::IsMember({"curves", "gamut-maps"}));
  add_setting_options(*app, job::Source::encode, job::Reach::cli, o->args);
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd contact-sheet Desk.exr -o desk-sheet.png\n"
      "  hdrd contact-sheet Desk.exr -o sheet.png --exposure -1 --tile-width 240 --columns 5\n"
      "  hdrd contact-sheet Wide.exr -o gamut-sheet.png --layout gamut-maps --tonemap bt2390\n"
      "The default mode here is sdr (an sRGB preview); exposure options apply to every tile.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("contact-sheet", 51, &hdrd::cli::setup)
