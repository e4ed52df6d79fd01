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

unsigned parse_mode_octal(const std::string& s, const std::string& source) {
  if (s.empty() || s.size() > 4 || s.find_first_not_of("01234567") != std::string::npos)
    config_fail(source, "server.socket_mode must be an octal string such as \"0660\"", "server.socket_mode");
  return unsigned(std::stoul(s, nullptr, 8));
}

}  // namespace

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

  Section server(root, "server", source);
  std::string mode = "0660";
  server.read("socket_path", c.server.socket_path);
  server.read("socket_mode", mode);
  c.server.socket_mode = parse_mode_octal(mode, source);
  server.read("socket_group", c.server.socket_group);
  server.read("systemd_activation", c.server.systemd_activation);
  server.read("tcp_listen", c.server.tcp_listen);
  server.read("tcp_allow_non_loopback", c.server.tcp_allow_non_loopback);
  server.read("token", c.server.token);
  server.read("token_file", c.server.token_file);
  server.read("connection_timeout_s", c.server.connection_timeout_s);
  server.read("max_connections", c.server.max_connections);
  server.read("max_connections_per_peer", c.server.max_connections_per_peer);
  server.read("header_timeout_s", c.server.header_timeout_s);
  server.read("body_grace_s", c.server.body_grace_s);
  server.read("min_body_bytes_per_s", c.server.min_body_bytes_per_s);
  server.read("http_threads", c.server.http_threads);
  server.read("drain_timeout_s", c.server.drain_timeout_s);
  server.finish();

  Section workers(root, "workers", source);
  workers.read("render_workers", c.workers.render_workers);
  workers.read("encode_threads", c.workers.encode_threads);
  workers.read("queue_depth", c.workers.queue_depth);
  workers.read("backend", c.workers.backend);
  workers.read("coalesce", c.workers.coalesce);
  workers.read("retry_after_s", c.workers.retry_after_s);
  workers.read("memory_budget_bytes", c.workers.memory_budget_bytes);
  workers.finish();

  Section sequences(root, "sequences", source);
  sequences.read("max_running", c.sequences.max_running);
  sequences.read("max_queued", c.sequences.max_queued);
  sequences.read("history", c.sequences.history);
  sequences.finish();

  Section cluster(root, "cluster", source);
  cluster.read("slurm_scripts_dir", c.cluster.slurm_scripts_dir);
  cluster.read("slurm_bin_dir", c.cluster.slurm_bin_dir);
  cluster.read("slurm_conf", c.cluster.slurm_conf);
  cluster.read("hdrd_program", c.cluster.hdrd_program);
  cluster.read("sbatch_options", c.cluster.sbatch_options);
  cluster.read("command_timeout_ms", c.cluster.command_timeout_ms);
  cluster.finish();

  Section paths(root, "paths", source);
  paths.read("asset_root", c.paths.asset_root);
  paths.read("dump_dir", c.paths.dump_dir);
  paths.read("allow_hard_links", c.paths.allow_hard_links);
  paths.finish();

  Section limits(root, "limits", source);
  limits.read("max_width", c.limits.max_width);
  limits.read("max_height", c.limits.max_height);
  limits.read("max_pixels", c.limits.max_pixels);
  limits.read("max_samples", c.limits.max_samples);
  limits.read("max_lights", c.limits.max_lights);
  limits.read("max_body_bytes", c.limits.max_body_bytes);
  limits.read("max_upload_bytes", c.limits.max_upload_bytes);
  limits.read("max_ui_bytes", c.limits.max_ui_bytes);
  limits.read("max_json_depth", c.limits.max_json_depth);
  limits.read("max_request_seconds", c.limits.max_request_seconds);
  limits.finish();

  Section log(root, "log", source);
  log.read("level", c.log.level);
  log.read("access_log", c.log.access_log);
  log.finish();

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
  const auto& s = c.server;
  const auto& w = c.workers;
  const auto& l = c.limits;
  return {
      {"source", c.source.string()},
      {"server",
       {{"socket_path", s.socket_path.string()}, {"socket_mode", fmt::format("{:04o}", s.socket_mode)},
        {"socket_group", s.socket_group}, {"systemd_activation", s.systemd_activation},
        {"tcp_listen", s.tcp_listen}, {"tcp_allow_non_loopback", s.tcp_allow_non_loopback},
        {"token", s.token.empty() ? "" : "(set)"}, {"token_file", s.token_file.string()},
        {"connection_timeout_s", s.connection_timeout_s}, {"max_connections", s.max_connections},
        {"max_connections_per_peer", s.max_connections_per_peer}, {"header_timeout_s", s.header_timeout_s},
        {"body_grace_s", s.body_grace_s}, {"min_body_bytes_per_s", s.min_body_bytes_per_s},
        {"http_threads", s.http_threads}, {"drain_timeout_s", s.drain_timeout_s}}},
      {"workers",
       {{"render_workers", w.render_workers}, {"encode_threads", w.encode_threads}, {"queue_depth", w.queue_depth},
        {"backend", w.backend}, {"coalesce", w.coalesce}, {"retry_after_s", w.retry_after_s},
        {"memory_budget_bytes", w.memory_budget_bytes}}},
      {"sequences",
       {{"max_running", c.sequences.max_running}, {"max_queued", c.sequences.max_queued},
        {"history", c.sequences.history}}},
      {"cluster",
       {{"slurm_scripts_dir", c.cluster.slurm_scripts_dir.string()}, {"slurm_bin_dir", c.cluster.slurm_bin_dir.string()},
        {"slurm_conf", c.cluster.slurm_conf.string()}, {"hdrd_program", c.cluster.hdrd_program},
        {"sbatch_options", c.cluster.sbatch_options}, {"command_timeout_ms", c.cluster.command_timeout_ms}}},
      {"paths",
       {{"asset_root", c.paths.asset_root.string()}, {"dump_dir", c.paths.dump_dir.string()},
        {"allow_hard_links", c.paths.allow_hard_links}}},
      {"limits",
       {{"max_width", l.max_width}, {"max_height", l.max_height}, {"max_pixels", l.max_pixels},
        {"max_samples", l.max_samples}, {"max_lights", l.max_lights}, {"max_body_bytes", l.max_body_bytes},
        {"max_upload_bytes", l.max_upload_bytes}, {"max_ui_bytes", l.max_ui_bytes},
        {"max_json_depth", l.max_json_depth}, {"max_request_seconds", l.max_request_seconds}}},
      {"log", {{"level", c.log.level}, {"access_log", c.log.access_log}}},
  };
}

}  // namespace hdrd::daemon
