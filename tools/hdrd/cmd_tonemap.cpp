// hdrd tonemap --list / --show NAME: the tone-curve registry.
#include <nlohmann/json.hpp>

#include "encode/tone/tonemap.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

struct Options {
  CommonOptions common;
  bool list = false;
  std::string show;
  double peak = 1000, paper_white = 203;
  std::vector<double> evaluate;
};

nlohmann::json describe(const tonemap::ToneCurveInfo& c) {
  nlohmann::json params = nlohmann::json::array();
  for (const auto& p : c.params)
    params.push_back({{"name", p.name}, {"description", p.description}, {"min", p.min}, {"max", p.max},
                      {"default", p.default_value}});
  return {{"name", c.name},
          {"description", c.description},
          {"source", c.source},
          {"apply", tonemap::to_string(c.default_apply)},
          {"scalar", c.scalar},
          {"has_inverse", c.has_inverse},
          {"keeps_reference_white", c.keeps_reference_white},
          {"params", params}};
}

void run(const Options& o) {
  if (!o.show.empty()) {
    const auto* c = tonemap::find_curve(o.show);
    if (!c) throw CliError("unknown tone curve '" + o.show + "' (see hdrd tonemap --list)");
    nlohmann::json j = describe(*c);
    auto curve = tonemap::prepare(c->name, {o.peak, 0, o.paper_white}).value();
    nlohmann::json samples = nlohmann::json::array();
    for (double x : o.evaluate.empty() ? std::vector<double>{0.01, 0.18, 1, 2, 4, 16, 100} : o.evaluate)
      samples.push_back({{"x", x}, {"y", curve->map(x)}, {"nits", curve->map(x) * o.paper_white}});
    j["samples"] = {{"peak_nits", o.peak}, {"paper_white_nits", o.paper_white}, {"values", samples}};
    if (o.common.json) return print_out(j.dump(2));
    std::string s = fmt::format("{}: {}\n  source: {}\n  default apply: {}\n", c->name, c->description, c->source,
                                tonemap::to_string(c->default_apply));
    for (const auto& p : c->params)
      s += fmt::format("  {} = {} [{}, {}]: {}\n", p.name, p.default_value, p.min, p.max, p.description);
    for (const auto& v : samples)
      s += fmt::format("  x = {:<8} -> {:.6f} x paper white = {:.2f} cd/m2\n", v["x"].get<double>(),
                       v["y"].get<double>(), v["nits"].get<double>());
    return print_out(s);
  }
  nlohmann::json list = nlohmann::json::array();
  std::string s;
  for (const auto& c : tonemap::curves()) {
    list.push_back(describe(c));
    s += fmt::format("{:20} {}{}\n", c.name, c.description, c.keeps_reference_white ? " [keeps reference white]" : "");
  }
  print_out(o.common.json ? list.dump(2) : s);
}

void setup(CLI::App& root) {
  auto o = std::make_shared<Options>();
  auto* app = root.add_subcommand("tonemap", "List the tone curves, or show one with its parameters and samples");
  app->add_flag("--list", o->list, "List every registered curve (the default)");
  app->add_option("--show", o->show, "Show one curve: parameters and sample values");
  app->add_option("--peak", o->peak, "Display peak for --show samples, cd/m2");
  app->add_option("--paper-white", o->paper_white, "Paper white for --show samples, cd/m2");
  app->add_option("--eval", o->evaluate, "Relative scene values to evaluate with --show");
  add_common_options(*app, o->common);
  app->footer(
      "Examples:\n"
      "  hdrd tonemap --list\n"
      "  hdrd tonemap --list --json\n"
      "  hdrd tonemap --show bt2390 --peak 600 --eval 1 --eval 4");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("tonemap", 60, &hdrd::cli::setup)
