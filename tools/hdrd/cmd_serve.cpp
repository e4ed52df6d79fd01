// hdrd serve: the daemon. HTTP/1.1 over a Unix socket (docs/api.md); config from
// config/hdrd.toml, command-line flags override it; SIGHUP reloads, SIGTERM/SIGINT drain
// and stop.
#include <sys/socket.h>
#include <sys/un.h>
#include <signal.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <optional>

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include "daemon/config.hpp"
#include "daemon/log_escape.hpp"
#include "daemon/service.hpp"
#include "tools/hdrd/command.hpp"

namespace hdrd::cli {
namespace {

namespace fs = std::filesystem;
using daemon::Config;

struct ServeOptions {
  CommonOptions common;
  std::string config_path;
  bool print_config = false;
  std::optional<std::string> socket, socket_mode, socket_group, tcp, token_file, asset_root, dump_dir, backend,
      log_level;
  std::optional<int> render_workers, encode_threads, queue_depth, connection_timeout_s, http_threads;
  std::optional<double> drain_timeout_s, max_request_seconds;
  std::optional<std::size_t> max_body_bytes, max_upload_bytes;
  std::optional<int> max_width, max_height;
  bool no_socket_activation = false;
  bool no_coalesce = false;
};

// The config file: --config, else $HDRD_CONFIG, else the first of
// $XDG_CONFIG_HOME/hdrd/hdrd.toml and /etc/hdrd/hdrd.toml that exists; none: defaults.
std::optional<fs::path> find_config(const ServeOptions& o) {
  if (!o.config_path.empty()) return fs::path(o.config_path);
  if (const char* e = std::getenv("HDRD_CONFIG"); e && *e) return fs::path(e);
  std::vector<fs::path> candidates;
  if (const char* x = std::getenv("XDG_CONFIG_HOME"); x && *x) candidates.push_back(fs::path(x) / "hdrd/hdrd.toml");
  else if (const char* h = std::getenv("HOME"); h && *h) candidates.push_back(fs::path(h) / ".config/hdrd/hdrd.toml");
  candidates.push_back("/etc/hdrd/hdrd.toml");
  std::error_code ec;
  for (const auto& c : candidates)
    if (fs::is_regular_file(c, ec)) return c;
  return std::nullopt;
}

Config load(const ServeOptions& o) {
  const auto path = find_config(o);
  Config c = path ? daemon::load_config(*path) : Config{};
  // Command-line flags override the file.
  auto& s = c.server;
  if (o.socket) s.socket_path = *o.socket;
  if (o.socket_mode) {
    if (o.socket_mode->find_first_not_of("01234567") != std::string::npos || o.socket_mode->empty())
      throw CliError("--socket-mode must be octal, e.g. 0660");
    s.socket_mode = unsigned(std::stoul(*o.socket_mode, nullptr, 8));
  }
  if (o.socket_group) s.socket_group = *o.socket_group;
  if (o.tcp) s.tcp_listen = *o.tcp;
  if (o.token_file) s.token_file = *o.token_file;
  if (o.connection_timeout_s) s.connection_timeout_s = *o.connection_timeout_s;
  if (o.http_threads) s.http_threads = *o.http_threads;
  if (o.drain_timeout_s) s.drain_timeout_s = *o.drain_timeout_s;
  if (o.no_socket_activation) s.systemd_activation = false;
  if (o.asset_root) c.paths.asset_root = *o.asset_root;
  if (o.dump_dir) c.paths.dump_dir = *o.dump_dir;
  if (o.render_workers) c.workers.render_workers = *o.render_workers;
  if (o.encode_threads) c.workers.encode_threads = *o.encode_threads;
  if (o.queue_depth) c.workers.queue_depth = *o.queue_depth;
  if (o.backend) c.workers.backend = *o.backend;
  if (o.no_coalesce) c.workers.coalesce = false;
  if (o.log_level) c.log.level = *o.log_level;
  if (o.max_request_seconds) c.limits.max_request_seconds = *o.max_request_seconds;
  if (o.max_body_bytes) c.limits.max_body_bytes = *o.max_body_bytes;
  if (o.max_upload_bytes) c.limits.max_upload_bytes = *o.max_upload_bytes;
  if (o.max_width) c.limits.max_width = *o.max_width;
  if (o.max_height) c.limits.max_height = *o.max_height;
  if (!path) c.source = "(built-in defaults)";
  daemon::validate_config(c);
  return c;
}

// sd_notify(3) without libsystemd: one datagram to $NOTIFY_SOCKET ('@' = abstract).
void notify_systemd(const char* state) {
  const char* path = std::getenv("NOTIFY_SOCKET");
  if (!path || !*path) return;
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::size_t n = std::strlen(path);
  if (n >= sizeof addr.sun_path) return;
  std::memcpy(addr.sun_path, path, n);
  if (addr.sun_path[0] == '@') addr.sun_path[0] = '\0';
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return;
  ::sendto(fd, state, std::strlen(state), MSG_NOSIGNAL, reinterpret_cast<sockaddr*>(&addr),
           socklen_t(offsetof(sockaddr_un, sun_path) + n));
  ::close(fd);
}

void run(const ServeOptions& o) {
  auto logger = spdlog::stderr_color_mt("hdrd");
  spdlog::set_default_logger(logger);
  // Every message is escaped (daemon/log_escape.hpp): much of what is logged comes from clients.
  daemon::set_escaped_log_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  Config config = load(o);
  if (o.print_config) {
    print_out(daemon::config_json(config).dump(2));
    return;
  }
  // Signals are taken synchronously by this thread; every thread started below inherits
  // the mask, so none of them is interrupted by SIGHUP/SIGTERM.
  sigset_t set;
  sigemptyset(&set);
  for (int s : {SIGHUP, SIGTERM, SIGINT}) sigaddset(&set, s);
  pthread_sigmask(SIG_BLOCK, &set, nullptr);
  ::signal(SIGPIPE, SIG_IGN);

  daemon::Service service(config);
  service.start();
  spdlog::info("hdrd {} serving on {} (config: {})", HDRD_VERSION_STRING, service.socket_description(),
               config.source.string());
  notify_systemd("READY=1");
  for (;;) {
    int sig = 0;
    if (sigwait(&set, &sig) != 0) continue;
    if (sig == SIGHUP) {
      notify_systemd("RELOADING=1");
      try {
        service.reload(load(o));
      } catch (const std::exception& e) {
        spdlog::error("reload failed, keeping the current configuration: {}", e.what());
      }
      notify_systemd("READY=1");
      continue;
    }
    spdlog::info("{} received", sig == SIGTERM ? "SIGTERM" : "SIGINT");
    notify_systemd("STOPPING=1");
    break;
  }
  service.shutdown();
}

void setup(CLI::App& root) {
  auto o = std::make_shared<ServeOptions>();
  CLI::App* app = root.add_subcommand("serve", "Run the daemon: HTTP/1.1 API over a Unix socket (docs/api.md)");
  add_common_options(*app, o->common);
  app->add_option("-c,--config", o->config_path,
                  "Config file (default: $HDRD_CONFIG, ~/.config/hdrd/hdrd.toml, /etc/hdrd/hdrd.toml)");
  app->add_flag("--print-config", o->print_config, "Print the effective configuration as JSON and exit");
  app->add_option("--socket", o->socket, "Unix socket path (default: $XDG_RUNTIME_DIR/hdrd.sock or /run/hdrd/hdrd.sock)");
  app->add_option("--socket-mode", o->socket_mode, "Socket permissions, octal (default 0660)");
  app->add_option("--socket-group", o->socket_group, "Group that may connect to the socket");
  app->add_option("--tcp", o->tcp, "Also listen on TCP host:port (loopback; needs --token-file)");
  app->add_option("--token-file", o->token_file, "File holding the bearer token TCP clients must send");
  app->add_option("--asset-root", o->asset_root, "Directory requests may read scenes, LUTs and UI PNGs from");
  app->add_option("--dump-dir", o->dump_dir, "Directory \"dump\": true requests write into");
  app->add_option("--render-workers", o->render_workers, "Render workers (one GL context each)");
  app->add_option("--encode-threads", o->encode_threads, "CPU encode threads");
  app->add_option("--queue-depth", o->queue_depth, "Requests that may wait beyond the running ones (then 503)");
  app->add_option("--backend", o->backend, "Renderer backend: auto, egl, egl-device, egl-surfaceless, osmesa");
  app->add_option("--connection-timeout", o->connection_timeout_s, "Seconds before an idle or slow client is dropped");
  app->add_option("--http-threads", o->http_threads, "HTTP polling threads");
  app->add_option("--drain-timeout", o->drain_timeout_s, "Seconds SIGTERM waits for in-flight requests");
  app->add_option("--max-request-seconds", o->max_request_seconds, "Time limit per request");
  app->add_option("--max-body-bytes", o->max_body_bytes, "Largest JSON request body");
  app->add_option("--max-upload-bytes", o->max_upload_bytes, "Largest EXR upload");
  app->add_option("--max-width", o->max_width, "Largest frame width");
  app->add_option("--max-height", o->max_height, "Largest frame height");
  app->add_option("--log-level", o->log_level, "trace, debug, info, warn, error, off");
  app->add_flag("--no-socket-activation", o->no_socket_activation, "Ignore LISTEN_FDS from systemd");
  app->add_flag("--no-coalesce", o->no_coalesce, "Never share work between identical concurrent requests");
  app->footer(
      "Examples:\n"
      "  hdrd serve                                   # $XDG_RUNTIME_DIR/hdrd.sock\n"
      "  hdrd serve --socket /tmp/hdrd.sock --asset-root ~/scenes --dump-dir /tmp/frames\n"
      "  hdrd serve -c config/hdrd.toml --print-config\n"
      "  curl --unix-socket \"$XDG_RUNTIME_DIR/hdrd.sock\" http://localhost/v1/status\n"
      "Signals: SIGHUP reloads the config file; SIGTERM/SIGINT stop accepting and drain.");
  app->callback([o] { run(*o); });
}

}  // namespace
}  // namespace hdrd::cli

HDRD_REGISTER_COMMAND("serve", 80, &hdrd::cli::setup)
