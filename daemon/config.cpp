#include "daemon/config.hpp"
#include "encode/image.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <optional>
#include <variant>

#include <fmt/format.h>
#include <toml++/toml.h>

namespace fs = std::filesystem;

namespace hdrd::daemon {
namespace {

[[noreturn]] void config_fail(const std::string& where, const std::string& message, const std::string& key) {
  throw HdrdError(make_error("config.invalid", where + ": " + message, key));
}

std::string where(const std::string& source, const toml::node& n) {
  const auto& s = n.source();
  return fmt::format("{}:{}", source, s.begin.line);
}

// Reads the keys of one TOML table; finish() refuses keys nobody read.
class Section {
 public:
  Section(const toml::table& root, std::string name, std::string source) : name_(std::move(name)), source_(std::move(source)) {
    if (const toml::node* n = root.get(name_)) {
      table_ = n->as_table();
      if (!table_) config_fail(where(source_, *n), "[" + name_ + "] must be a table", name_);
    }
  }

  template <class T>
  void read(std::string_view key, T& out) {
    seen_.insert(std::string(key));
    if (!table_) return;
    const toml::node* n = table_->get(key);
    if (!n) return;
    const std::string full = name_ + "." + std::string(key);
    if constexpr (std::is_same_v<T, bool>) {
      if (!n->is_boolean()) config_fail(where(source_, *n), full + " must be true or false", full);
      out = n->value<bool>().value();
    } else if constexpr (std::is_integral_v<T>) {
      if (!n->is_integer()) config_fail(where(source_, *n), full + " must be an integer", full);
      const auto v = n->value<std::int64_t>().value();
      if (v < 0 || std::uint64_t(v) > std::uint64_t(std::numeric_limits<T>::max()))
        config_fail(where(source_, *n), fmt::format("{} = {} is out of range", full, v), full);
      out = T(v);
    } else if constexpr (std::is_floating_point_v<T>) {
      if (!n->is_number()) config_fail(where(source_, *n), full + " must be a number", full);
      out = n->value<double>().value();
      if (!std::isfinite(out) || out < 0) config_fail(where(source_, *n), full + " must be a finite number >= 0", full);
    } else if constexpr (std::is_same_v<T, fs::path>) {
      if (!n->is_string()) config_fail(where(source_, *n), full + " must be a string (a path)", full);
      out = fs::path(n->value<std::string>().value());
    } else {
      if (!n->is_string()) config_fail(where(source_, *n), full + " must be a string", full);
      out = n->value<std::string>().value();
    }
  }

  void finish() const {
    if (!table_) return;
    for (auto&& [k, v] : *table_)
      if (!seen_.count(std::string(k.str())))
        config_fail(where(source_, v), fmt::format("unknown key {}.{}", name_, k.str()), name_ + "." + std::string(k.str()));
  }

 private:
  std::string name_, source_;
  const toml::table* table_ = nullptr;
  std::set<std::string> seen_;
};

unsigned parse_mode_octal(const std::string& s, const std::string& source, const std::string& key) {
  if (s.empty() || s.size() > 4 || s.find_first_not_of("01234567") != std::string::npos)
    config_fail(source, key + " must be an octal string such as \"0660\"", key);
  return unsigned(std::stoul(s, nullptr, 8));
}

}  // namespace

// The table. Order is hdrd.toml's (config/hdrd.toml) and hdrd.toml(5)'s.
std::span<const ConfigKey> config_keys() {
  static const ConfigKey kKeys[] = {
      {"server", "socket_path", [](Config& c) -> ConfigField { return &c.server.socket_path; }},
      {"server", "socket_mode", [](Config& c) -> ConfigField { return &c.server.socket_mode; }},
      {"server", "socket_group", [](Config& c) -> ConfigField { return &c.server.socket_group; }},
      {"server", "systemd_activation", [](Config& c) -> ConfigField { return &c.server.systemd_activation; }},
      {"server", "tcp_listen", [](Config& c) -> ConfigField { return &c.server.tcp_listen; }},
      {"server", "tcp_allow_non_loopback", [](Config& c) -> ConfigField { return &c.server.tcp_allow_non_loopback; }},
      {"server", "token", [](Config& c) -> ConfigField { return &c.server.token; }},
      {"server", "token_file", [](Config& c) -> ConfigField { return &c.server.token_file; }},
      {"server", "connection_timeout_s", [](Config& c) -> ConfigField { return &c.server.connection_timeout_s; }},
      {"server", "max_connections", [](Config& c) -> ConfigField { return &c.server.max_connections; }},
      {"server", "max_connections_per_peer", [](Config& c) -> ConfigField { return &c.server.max_connections_per_peer; }},
      {"server", "header_timeout_s", [](Config& c) -> ConfigField { return &c.server.header_timeout_s; }},
      {"server", "body_grace_s", [](Config& c) -> ConfigField { return &c.server.body_grace_s; }},
      {"server", "min_body_bytes_per_s", [](Config& c) -> ConfigField { return &c.server.min_body_bytes_per_s; }},
      {"server", "http_threads", [](Config& c) -> ConfigField { return &c.server.http_threads; }},
      {"server", "drain_timeout_s", [](Config& c) -> ConfigField { return &c.server.drain_timeout_s; }},
      {"workers", "render_workers", [](Config& c) -> ConfigField { return &c.workers.render_workers; }},
      {"workers", "encode_threads", [](Config& c) -> ConfigField { return &c.workers.encode_threads; }},
      {"workers", "queue_depth", [](Config& c) -> ConfigField { return &c.workers.queue_depth; }},
      {"workers", "backend", [](Config& c) -> ConfigField { return &c.workers.backend; }},
      {"workers", "coalesce", [](Config& c) -> ConfigField { return &c.workers.coalesce; }},
      {"workers", "retry_after_s", [](Config& c) -> ConfigField { return &c.workers.retry_after_s; }},
      {"workers", "memory_budget_bytes", [](Config& c) -> ConfigField { return &c.workers.memory_budget_bytes; }},
      {"sequences", "max_running", [](Config& c) -> ConfigField { return &c.sequences.max_running; }},
      {"sequences", "max_queued", [](Config& c) -> ConfigField { return &c.sequences.max_queued; }},
      {"sequences", "history", [](Config& c) -> ConfigField { return &c.sequences.history; }},
      {"cluster", "slurm_scripts_dir", [](Config& c) -> ConfigField { return &c.cluster.slurm_scripts_dir; }},
      {"cluster", "slurm_bin_dir", [](Config& c) -> ConfigField { return &c.cluster.slurm_bin_dir; }},
      {"cluster", "slurm_conf", [](Config& c) -> ConfigField { return &c.cluster.slurm_conf; }},
      {"cluster", "hdrd_program", [](Config& c) -> ConfigField { return &c.cluster.hdrd_program; }},
      {"cluster", "sbatch_options", [](Config& c) -> ConfigField { return &c.cluster.sbatch_options; }},
      {"cluster", "command_timeout_ms", [](Config& c) -> ConfigField { return &c.cluster.command_timeout_ms; }},
      {"paths", "asset_root", [](Config& c) -> ConfigField { return &c.paths.asset_root; }},
      {"paths", "dump_dir", [](Config& c) -> ConfigField { return &c.paths.dump_dir; }},
      {"paths", "allow_hard_links", [](Config& c) -> ConfigField { return &c.paths.allow_hard_links; }},
      {"limits", "max_width", [](Config& c) -> ConfigField { return &c.limits.max_width; }},
      {"limits", "max_height", [](Config& c) -> ConfigField { return &c.limits.max_height; }},
      {"limits", "max_pixels", [](Config& c) -> ConfigField { return &c.limits.max_pixels; }},
      {"limits", "max_samples", [](Config& c) -> ConfigField { return &c.limits.max_samples; }},
      {"limits", "max_lights", [](Config& c) -> ConfigField { return &c.limits.max_lights; }},
      {"limits", "max_body_bytes", [](Config& c) -> ConfigField { return &c.limits.max_body_bytes; }},
      {"limits", "max_upload_bytes", [](Config& c) -> ConfigField { return &c.limits.max_upload_bytes; }},
      {"limits", "max_ui_bytes", [](Config& c) -> ConfigField { return &c.limits.max_ui_bytes; }},
      {"limits", "max_json_depth", [](Config& c) -> ConfigField { return &c.limits.max_json_depth; }},
      {"limits", "max_request_seconds", [](Config& c) -> ConfigField { return &c.limits.max_request_seconds; }},
      {"log", "level", [](Config& c) -> ConfigField { return &c.log.level; }},
      {"log", "access_log", [](Config& c) -> ConfigField { return &c.log.access_log; }},
  };
  return kKeys;
}

fs::path default_socket_path() {
  if (const char* x = std::getenv("XDG_RUNTIME_DIR"); x && *x) return fs::path(x) / "hdrd.sock";
  return "/run/hdrd/hdrd.sock";
}

Config parse_config(std::string_view text, const std::string& source) {
  toml::table root;
  try {
    root = toml::parse(text, source);
  } catch (const toml::parse_error& e) {
    config_fail(fmt::format("{}:{}", source, e.source().begin.line), std::string(e.description()), "");
  }
  for (auto&& [k, v] : root) {
    if (k.str() == "render")
      config_fail(where(source, v),
                  "[render] is gone: a request's defaults (scene, size, samples) are the settings table's, the same "
                  "for hdrd and the daemon (docs/settings.md)",
                  "render");
    static const std::set<std::string> kSections = {"server", "workers", "sequences", "cluster", "paths", "limits", "log"};
    if (!kSections.count(std::string(k.str())))
      config_fail(where(source, v), fmt::format("unknown section [{}]", k.str()), std::string(k.str()));
  }
  Config c;
  c.source = source;
  // Every key of the table, section by section; each section then refuses keys it does not know.
  std::string_view open;
  std::optional<Section> section;
  for (const auto& k : config_keys()) {
    if (k.section != open) {
      if (section) section->finish();
      section.emplace(root, std::string(k.section), source);
      open = k.section;
    }
    std::visit(
        [&](auto* field) {
          using T = std::remove_pointer_t<decltype(field)>;
          if constexpr (std::is_same_v<T, unsigned>) {  // a file mode, written as an octal string
            std::string mode = fmt::format("{:04o}", *field);
            section->read(k.key, mode);
            *field = parse_mode_octal(mode, source, std::string(k.section) + "." + std::string(k.key));
          } else {
            section->read(k.key, *field);
          }
        },
        k.field(c));
  }
  if (section) section->finish();

  validate_config(c);
  return c;
}

Config load_config(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw HdrdError(make_error("config.not_found", "cannot read config file " + file.string(), "config"));
  std::ostringstream ss;
  ss << in.rdbuf();
  return parse_config(ss.str(), file.string());
}

void validate_config(const Config& c) {
  auto need = [&](bool ok, const std::string& key, const std::string& why) {
    if (!ok) throw HdrdError(make_error("config.invalid", fmt::format("{}: {} {}", c.source.string(), key, why), key));
  };
  // Every count, size and duration has a range: a value that parses (1e300 seconds) may
  // still overflow what it feeds (a deadline), so "positive" is not enough.
  auto range = [&](const std::string& key, auto v, auto lo, auto hi) {
    using T = decltype(v);
    need(v >= T(lo) && v <= T(hi), key, fmt::format("= {} is outside [{}, {}]", v, lo, hi));
  };
  const auto& s = c.server;
  need(s.socket_mode <= 0777, "server.socket_mode", "must be at most 0777");
  need((s.socket_mode & 0007) == 0, "server.socket_mode", "must not grant access to others (only owner and group)");
  range("server.connection_timeout_s", s.connection_timeout_s, 1, 3600);
  range("server.max_connections", s.max_connections, 1, 65536);
  range("server.max_connections_per_peer", s.max_connections_per_peer, 1, s.max_connections);
  range("server.header_timeout_s", s.header_timeout_s, 0.1, 3600.0);
  range("server.body_grace_s", s.body_grace_s, 0.0, 3600.0);
  range("server.min_body_bytes_per_s", s.min_body_bytes_per_s, 1u, 1ull << 40);
  range("server.http_threads", s.http_threads, 1, 64);
  range("server.drain_timeout_s", s.drain_timeout_s, 0.0, 3600.0);
  const auto& w = c.workers;
  range("workers.render_workers", w.render_workers, 1, 64);
  range("workers.encode_threads", w.encode_threads, 1, 256);
  range("workers.queue_depth", w.queue_depth, 0, 65536);
  range("workers.retry_after_s", w.retry_after_s, 0, 3600);
  if (w.memory_budget_bytes != 0) range("workers.memory_budget_bytes", w.memory_budget_bytes, 64ull << 20, 1ull << 50);
  static const std::set<std::string> kBackends = {"auto", "egl", "egl-device", "egl-surfaceless", "osmesa"};
  need(kBackends.count(w.backend) > 0, "workers.backend", "must be auto, egl, egl-device, egl-surfaceless or osmesa");
  const auto& l = c.limits;
  range("sequences.max_running", c.sequences.max_running, 1, 64);
  range("sequences.max_queued", c.sequences.max_queued, 0, 65536);
  range("sequences.history", c.sequences.history, 1, 100000);
  range("cluster.command_timeout_ms", c.cluster.command_timeout_ms, 100, 3600000);
  range("limits.max_width", l.max_width, 1, kMaxImageDimension);
  range("limits.max_height", l.max_height, 1, kMaxImageDimension);
  range("limits.max_pixels", l.max_pixels, 1, kMaxImagePixels);
  range("limits.max_samples", l.max_samples, 1, 64);
  range("limits.max_lights", l.max_lights, 0, 65536);
  range("limits.max_body_bytes", l.max_body_bytes, 1024u, std::size_t(1) << 30);
  range("limits.max_upload_bytes", l.max_upload_bytes, 1024u, std::size_t(4) << 30);
  range("limits.max_ui_bytes", l.max_ui_bytes, 1024u, std::size_t(1) << 30);
  range("limits.max_json_depth", l.max_json_depth, 4, 256);
  // A day: far beyond any frame, and far inside what steady_clock's nanoseconds can add.
  range("limits.max_request_seconds", l.max_request_seconds, 0.001, 86400.0);
  static const std::set<std::string> kLevels = {"trace", "debug", "info", "warn", "error", "critical", "off"};
  need(kLevels.count(c.log.level) > 0, "log.level", "must be one of trace, debug, info, warn, error, critical, off");
  if (!s.tcp_listen.empty())
    need(!s.token.empty() || !s.token_file.empty(), "server.tcp_listen",
         "needs server.token or server.token_file (TCP requires a bearer token)");
}

void check_config_paths(const Config& c) {
  auto fail = [&](const std::string& key, const std::string& why) {
    throw HdrdError(make_error("config.invalid", fmt::format("{}: {} {}", c.source.string(), key, why), key));
  };
  std::error_code ec;
  if (!c.paths.asset_root.empty() && !fs::is_directory(c.paths.asset_root, ec))
    fail("paths.asset_root", c.paths.asset_root.string() + " is not a directory");
  const fs::path& dump = c.paths.dump_dir;
  if (dump.empty()) return;
  fs::create_directories(dump, ec);
  if (ec) fail("paths.dump_dir", "cannot be created: " + dump.string() + ": " + ec.message());
  if (!fs::is_directory(dump, ec)) fail("paths.dump_dir", dump.string() + " is not a directory");
  // The one honest test of writability (permissions, read-only mounts, a full disk):
  // create a file there, and remove it.
  const int fd = ::open(dump.c_str(), O_TMPFILE | O_WRONLY | O_CLOEXEC, 0600);
  if (fd >= 0) {
    ::close(fd);
    return;
  }
  if (errno != EOPNOTSUPP && errno != EISDIR && errno != EINVAL)  // O_TMPFILE unsupported: try a named file
    fail("paths.dump_dir", fmt::format("{} is not writable: {}", dump.string(), std::strerror(errno)));
  const fs::path probe = dump / fmt::format(".hdrd-write-test-{}", ::getpid());
  const int named = ::open(probe.c_str(), O_CREAT | O_EXCL | O_WRONLY | O_CLOEXEC, 0600);
  if (named < 0) fail("paths.dump_dir", fmt::format("{} is not writable: {}", dump.string(), std::strerror(errno)));
  ::close(named);
  ::unlink(probe.c_str());
}

std::uint64_t effective_memory_budget(const WorkerConfig& w) {
  if (w.memory_budget_bytes != 0) return w.memory_budget_bytes;
  // Half of the RAM, at most 4 GiB: an 8K frame, or a 4K frame with 4x MSAA and an EXR
  // answer, fits; an 8K frame with 16 samples (13 GiB by the estimate) does not.
  constexpr std::uint64_t kDefaultCap = 4ull << 30;
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page <= 0) return kDefaultCap;
  return std::min(kDefaultCap, std::uint64_t(pages) * std::uint64_t(page) / 2);
}

ConnectionLimits connection_limits(const ServerConfig& s) {
  return ConnectionLimits{s.max_connections, s.max_connections_per_peer, s.header_timeout_s, s.body_grace_s,
                          s.min_body_bytes_per_s};
}

nlohmann::json config_json(const Config& c) {
  nlohmann::json j = {{"source", c.source.string()}};
  Config copy = c;  // the table's accessors take a Config&
  for (const auto& k : config_keys()) {
    auto& out = j[std::string(k.section)][std::string(k.key)];
    std::visit(
        [&](auto* field) {
          using T = std::remove_pointer_t<decltype(field)>;
          if constexpr (std::is_same_v<T, unsigned>) out = fmt::format("{:04o}", *field);
          else if constexpr (std::is_same_v<T, fs::path>) out = field->string();
          else out = *field;
        },
        k.field(copy));
  }
  if (!c.server.token.empty()) j["server"]["token"] = "(set)";  // never printed
  return j;
}

}  // namespace hdrd::daemon
