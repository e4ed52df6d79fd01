// hdrd docs (hidden): hdrd(1), hdrd.toml(5) and hdrd's bash completion, written from the
// options of this program (the settings table's, through settings_cli) and from the
// daemon's table of configuration keys (daemon/config.hpp) with the comments of the
// commented configuration file. The build runs it (cmake/Docs.cmake); nothing is kept twice.
#include <fstream>
#include <map>
#include <sstream>

#include "daemon/config.hpp"
#include "shading/scene_loader.hpp"
#include "tools/common/cli_docs.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

struct DocsOptions {
  std::string what;
  std::string config_file = "config/hdrd.toml";
};

ManPage hdrd_page() {
  ManPage p{.name = "hdrd", .section = 1, .version = "hdrd " HDRD_VERSION_STRING,
            .summary = "headless HDR display-output service: render, encode, inspect displays, serve"};
  p.sections = {
      {"Files",
       "/etc/hdrd/hdrd.toml: the configuration of hdrd serve (hdrd.toml(5)).\n\n"
       "/run/hdrd/hdrd.sock: the socket of the system service (hdrd.socket), for the hdrd group.\n\n"
       "/var/lib/hdrd/dumps: where the service writes \"dump\": true requests.\n\n"
       "/usr/share/doc/hdrd: the documentation (docs/settings.md: every request setting; docs/api.md: the API)."},
      {"Environment",
       "HDRD_CONFIG: the configuration file of hdrd serve when --config is not given.\n\n"
       "XDG_RUNTIME_DIR: hdrd serve's default socket is $XDG_RUNTIME_DIR/hdrd.sock when it is set.\n\n"
       "EGL_PLATFORM: surfaceless picks a headless EGL (Mesa's llvmpipe without a GPU)."},
      {"Exit status", "0 on success, 1 on an error (one line on stderr), 2 on a usage error."},
  };
  p.see_also = {"hdrctl(1)", "hdrd.toml(5)", "systemctl(1)"};
  return p;
}

std::string trim_comment(const std::string& line) {
  if (line == "#") return "";
  return line.rfind("# ", 0) == 0 ? line.substr(2) : line.substr(1);
}

// hdrd.toml(5): every key of the table, with the comment above it in the commented file
// (config/hdrd.toml) and the value it gives there, which is the default (a test keeps it so).
// A key of the table missing from the file, or one of the file missing from the table, is an error.
std::string config_man(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw CliError("hdrd docs config-man: cannot read " + file);
  std::string line, section, description, comment, last_doc;
  std::map<std::string, std::pair<std::string, std::string>> found;  // "section.key" -> (value, text)
  bool header = true, adjacent = false;
  while (std::getline(in, line)) {
    if (line.rfind("#", 0) == 0) {
      comment += (comment.empty() ? "" : "\n") + trim_comment(line);
      adjacent = false;
      continue;
    }
    if (line.empty()) {
      if (header) description = comment, comment.clear(), header = false;
      adjacent = false;
      continue;
    }
    if (line.front() == '[') {
      section = line.substr(1, line.find(']') - 1);
      comment.clear();
      header = adjacent = false;
      continue;
    }
    const auto eq = line.find(" = ");
    if (eq == std::string::npos) throw CliError("hdrd docs config-man: " + file + ": cannot read the line: " + line);
    // A key right below another without a comment of its own shares its text (max_height).
    const std::string text = comment.empty() && adjacent ? last_doc : comment;
    found[section + "." + line.substr(0, eq)] = {line.substr(eq + 3), text};
    last_doc = text;
    comment.clear();
    adjacent = true;
  }
  std::vector<ManEntry> entries;
  for (const auto& k : daemon::config_keys()) {
    const std::string name = std::string(k.section) + "." + std::string(k.key);
    const auto it = found.find(name);
    if (it == found.end() || it->second.second.empty())
      throw CliError("hdrd docs config-man: " + name + " is not documented in " + file);
    entries.push_back({"[" + std::string(k.section) + "]", std::string(k.key) + " = " + it->second.first,
                       it->second.second});
    found.erase(it);
  }
  if (!found.empty())
    throw CliError("hdrd docs config-man: " + file + " has " + found.begin()->first +
                   ", which hdrd does not read (daemon/config.cpp config_keys)");
  ManPage p{.name = "hdrd.toml", .section = 5, .version = "hdrd " HDRD_VERSION_STRING,
            .summary = "configuration of the hdrd daemon (hdrd serve)"};
  p.sections = {{"Files", "/etc/hdrd/hdrd.toml: the system service's (hdrd.service).\n\n"
                          "/usr/share/doc/hdrd/examples/hdrd.toml.defaults: every key at its built-in default."}};
  p.see_also = {"hdrd(1)", "hdrctl(1)"};
  return man_page_entries(p, description, entries, "Keys");
}

void run(const DocsOptions& o, CLI::App& root) {
  // Scene names join the --scene completion (files complete too).
  ValueHint scenes{.files = true};
  for (auto& n : shading::builtin_scene_names()) scenes.words.push_back(n);
  set_value_hint_everywhere(root, "--scene", scenes);
  if (o.what == "man") return print_out(man_page(root, hdrd_page()));
  if (o.what == "bash-completion") return print_out(bash_completion(root));
  if (o.what == "config-man") return print_out(config_man(o.config_file));
  throw CliError("hdrd docs: unknown page '" + o.what + "' (man, config-man, bash-completion)");
}

void setup(CLI::App& root) {
  auto o = std::make_shared<DocsOptions>();
  auto* app = root.add_subcommand("docs", "Write hdrd(1), hdrd.toml(5) or hdrd's bash completion to stdout");
  app->add_option("what", o->what, "man, config-man or bash-completion")->required();
  app->add_option("--config-file", o->config_file, "config-man: the commented configuration file");
  app->group("");  // hidden: the build's tool, not the user's
  app->callback([o, &root] { run(*o, root); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("docs", 1000, &hdrd::cli::setup)
