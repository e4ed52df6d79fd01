// Daemon configuration: config/hdrd.toml (toml++), then command-line overrides.
// Start-up may throw (HdrdError with the file, key and reason); SIGHUP re-reads the file
// and applies what can change at run time (limits, roots, log level).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "job/request.hpp"

namespace hdrd::daemon {

using job::Limits;

struct ServerConfig {
  std::filesystem::path socket_path;       // empty: $XDG_RUNTIME_DIR/hdrd.sock or /run/hdrd/hdrd.sock
  unsigned socket_mode = 0660;             // only the owner and group may connect
  std::string socket_group;                // chgrp the socket to this group (empty: keep)
  bool systemd_activation = true;          // use an inherited LISTEN_FDS socket when present
  // Optional TCP listener; requires a bearer token.
  std::string tcp_listen;                  // "127.0.0.1:8765"; empty: no TCP
  bool tcp_allow_non_loopback = false;     // refuse non-loopback addresses unless set
  std::string token;                       // bearer token (or token_file)
  std::filesystem::path token_file;
  int connection_timeout_s = 30;           // idle/slow clients are closed after this
  int max_connections = 64;
  int http_threads = 2;                    // libmicrohttpd polling threads
  double drain_timeout_s = 30;             // SIGTERM: wait this long for in-flight requests
};

struct WorkerConfig {
  int render_workers = 1;                  // each owns one renderer (one GL context)
  int encode_threads = 2;                  // CPU encode pool
  int queue_depth = 16;                    // jobs waiting beyond the running ones; then 503
  std::string backend = "auto";            // auto, egl, egl-device, egl-surfaceless, osmesa
  bool coalesce = true;                    // identical concurrent requests share one job
  int retry_after_s = 1;                   // Retry-After on 503 queue.full
};

struct PathsConfig {
  std::filesystem::path asset_root;        // requests may name files only inside it
  std::filesystem::path dump_dir;          // "dump": true writes here, nowhere else
};

struct LogConfig {
  std::string level = "info";              // trace, debug, info, warn, error, off
  bool access_log = true;                  // one line per request
};

struct Config {
  ServerConfig server;
  WorkerConfig workers;
  PathsConfig paths;
  Limits limits;
  LogConfig log;
  std::filesystem::path source;            // the file it was read from (empty: defaults)
};

// Reads a TOML file. Unknown sections/keys and wrong types are errors (thrown as
// HdrdError naming file:line and key), so a typo never silently does nothing.
Config load_config(const std::filesystem::path& file);
Config parse_config(std::string_view toml_text, const std::string& source_name);

// Checks cross-field consistency (positive counts, mode bits, existing roots...).
void validate_config(const Config& c);

// The default socket path: $XDG_RUNTIME_DIR/hdrd.sock when set, else /run/hdrd/hdrd.sock.
std::filesystem::path default_socket_path();

// The effective configuration as JSON (token redacted), for `hdrd serve --print-config`.
nlohmann::json config_json(const Config& c);

}  // namespace hdrd::daemon
