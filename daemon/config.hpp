// Daemon configuration: config/hdrd.toml (toml++), then command-line overrides.
// Start-up may throw (HdrdError with the file, key and reason); SIGHUP re-reads the file
// and applies what can change at run time (limits, roots, log level).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string_view>
#include <variant>
#include <string>
#include <vector>

#include "daemon/http/connections.hpp"
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
  int connection_timeout_s = 30;           // a connection without a byte in either direction this long is closed
  // Connection caps and deadlines (connections.hpp; docs/api.md "Connections"). Defaults
  // from the measurements in docs/performance-daemon.md.
  int max_connections = 256;               // at the cap, the oldest connection waiting for a request makes room
  int max_connections_per_peer = 64;       // per uid (Unix socket) or address (TCP), the same way
  double header_timeout_s = 10;            // the whole request header, from connect or the previous reply
  double body_grace_s = 10;                // then the body must average at least min_body_bytes_per_s
  std::uint64_t min_body_bytes_per_s = 65536;
  int http_threads = 2;                    // libmicrohttpd polling threads
  double drain_timeout_s = 30;             // SIGTERM: wait this long for in-flight requests
};

struct WorkerConfig {
  int render_workers = 1;                  // each owns one renderer (one GL context)
  int encode_threads = 2;                  // CPU encode pool
  int queue_depth = 16;                    // jobs waiting beyond the running ones; then 503
  std::string backend = "auto";            // auto, egl, egl-device, egl-surfaceless, osmesa
  bool coalesce = true;                    // identical concurrent requests share one job
  int retry_after_s = 1;                   // Retry-After on 503 queue.full / queue.memory
  // Memory that admitted requests may use together, by their estimates (memory.hpp);
  // a request that would exceed it is answered 503 queue.memory. 0: half of the RAM, at most 4 GiB.
  std::uint64_t memory_budget_bytes = 0;
};

// POST /v1/sequences' jobs (jobs.hpp): they run on threads of their own, each with its own
// renderer, beside the single-frame workers.
struct SequencesConfig {
  int max_running = 1;                     // jobs rendering/encoding at once
  int max_queued = 16;                     // jobs waiting beyond those; then 503 queue.full
  int history = 100;                       // finished jobs kept for GET /v1/jobs (oldest forgotten)
};

// POST /v1/cluster/submissions (api_cluster.cpp, slurm.hpp): submitting sequence plans to a
// Slurm cluster. Off unless slurm_scripts_dir names deploy/slurm.
struct ClusterConfig {
  std::filesystem::path slurm_scripts_dir;  // deploy/slurm (shard.sbatch, merge.sbatch); empty: no cluster
  std::filesystem::path slurm_bin_dir;      // sbatch, squeue, sacct, scancel; empty: PATH
  std::filesystem::path slurm_conf;         // SLURM_CONF for them; empty: their default
  std::string hdrd_program = "hdrd";        // hdrd as the compute nodes see it
  std::string sbatch_options;               // given to both sbatch calls, split at spaces ("--partition=render")
  int command_timeout_ms = 30000;           // each sbatch/squeue/sacct/scancel
};

struct PathsConfig {
  std::filesystem::path asset_root;        // requests may name files only inside it
  std::filesystem::path dump_dir;          // "dump": true writes here, nowhere else
  bool allow_hard_links = false;           // a file in the asset root with st_nlink > 1 may be read
};

struct LogConfig {
  std::string level = "info";              // trace, debug, info, warn, error, off
  bool access_log = true;                  // one line per request
};

struct Config {
  ServerConfig server;
  WorkerConfig workers;
  SequencesConfig sequences;
  ClusterConfig cluster;
  PathsConfig paths;
  Limits limits;
  LogConfig log;
  std::filesystem::path source;            // the file it was read from (empty: defaults)
};

// One key of hdrd.toml: its section, name and the field it sets. The one table of the keys:
// the parser reads these and refuses others, config_json prints them, hdrd.toml(5) lists
// them (its text: the comment above each key in config/hdrd.toml; `hdrd docs config-man`).
using ConfigField = std::variant<bool*, int*, unsigned*, double*, std::int64_t*, std::uint64_t*, std::string*,
                                 std::filesystem::path*>;
struct ConfigKey {
  std::string_view section;
  std::string_view key;
  ConfigField (*field)(Config& c);
};
std::span<const ConfigKey> config_keys();

// Reads a TOML file. Unknown sections/keys and wrong types are errors (thrown as
// HdrdError naming file:line and key), so a typo never silently does nothing.
Config load_config(const std::filesystem::path& file);
Config parse_config(std::string_view toml_text, const std::string& source_name);

// Checks every count, size and duration against its range (a duration that parses but
// overflows a deadline, such as 1e300 s, is refused) and cross-field consistency.
void validate_config(const Config& c);

// What needs the file system: the dump directory exists (or is created) and a file can be
// written in it; the asset root, when set, is a directory. Run at start and on reload, so
// that a bad directory is reported then and not at the first request. Throws HdrdError.
void check_config_paths(const Config& c);

// workers.memory_budget_bytes as it applies: the configured value, or half of the RAM, at most 4 GiB.
std::uint64_t effective_memory_budget(const WorkerConfig& w);

// The connection caps and deadlines of [server].
ConnectionLimits connection_limits(const ServerConfig& s);

// The default socket path: $XDG_RUNTIME_DIR/hdrd.sock when set, else /run/hdrd/hdrd.sock.
std::filesystem::path default_socket_path();

// The effective configuration as JSON (token redacted), for `hdrd serve --print-config`.
nlohmann::json config_json(const Config& c);

}  // namespace hdrd::daemon
