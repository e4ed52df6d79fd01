// config/hdrd.toml: the shipped file parses and states the built-in defaults; unknown
// keys, wrong types and unsafe values are refused with file:line and the key.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "daemon/config.hpp"
#include "daemon/http/listener.hpp"
#include "tests/testing/testing.hpp"

namespace hdrd::daemon {
namespace {

Error config_error(const std::string& toml) {
  try {
    (void)parse_config(toml, "test.toml");
  } catch (const HdrdError& e) {
    return e.error();
  }
  return {};
}

TEST(Config, ShippedFileParsesAndMatchesTheDefaults) {
  const auto file = testing::source_dir() / "config/hdrd.toml";
  const Config shipped = load_config(file);
  const Config defaults;
  // The file documents every key with its default value: the two must agree.
  auto a = config_json(shipped), b = config_json(defaults);
  a.erase("source");
  b.erase("source");
  EXPECT_EQ(a.dump(2), b.dump(2));
}

TEST(Config, EveryDocumentedKeyIsInTheShippedFile) {
  const std::string text = testing::read_file(testing::source_dir() / "config/hdrd.toml");
  const auto all = config_json(Config{});  // kept: items() of a temporary would dangle
  for (const auto& [section, keys] : all.items()) {
    if (!keys.is_object()) continue;
    EXPECT_NE(text.find("[" + section + "]"), std::string::npos) << section;
    for (const auto& [key, v] : keys.items()) {
      EXPECT_NE(text.find("\n" + key + " = "), std::string::npos) << section << "." << key << " is not documented";
    }
  }
}

TEST(Config, ValuesAreRead) {
  const Config c = parse_config(R"(
[server]
socket_path = "/tmp/x.sock"
socket_mode = "0600"
[workers]
render_workers = 3
queue_depth = 0
[limits]
max_width = 1024
max_request_seconds = 2.5
[log]
level = "debug"
)", "t.toml");
  EXPECT_EQ(c.server.socket_path, "/tmp/x.sock");
  EXPECT_EQ(c.server.socket_mode, 0600u);
  EXPECT_EQ(c.workers.render_workers, 3);
  EXPECT_EQ(c.workers.queue_depth, 0);
  EXPECT_EQ(c.limits.max_width, 1024);
  EXPECT_DOUBLE_EQ(c.limits.max_request_seconds, 2.5);
  EXPECT_EQ(c.log.level, "debug");
}

TEST(Config, MistakesAreRefusedWithTheKey) {
  const std::pair<const char*, const char*> table[] = {
      {"[server]\nsocket_pth = \"x\"\n", "server.socket_pth"},
      {"[sever]\n", "sever"},
      {"[limits]\nmax_width = \"big\"\n", "limits.max_width"},
      {"[limits]\nmax_width = -1\n", "limits.max_width"},
      {"[limits]\nmax_width = 100000\n", "limits.max_width"},
      {"[server]\nsocket_mode = \"0666\"\n", "server.socket_mode"},
      {"[server]\nsocket_mode = \"rw\"\n", "server.socket_mode"},
      {"[server]\ntcp_listen = \"127.0.0.1:1\"\n", "server.tcp_listen"},
      {"[workers]\nbackend = \"vulkan\"\n", "workers.backend"},
      {"[workers]\nrender_workers = 0\n", "workers.render_workers"},
      {"[log]\nlevel = \"loud\"\n", "log.level"},
      {"[render]\ndefault_width = 640\n", "render"},  // gone: the settings table's defaults rule
      {"[limits]\nmax_request_seconds = true\n", "limits.max_request_seconds"},
      // Values that parse but would break everything (issue 14): every duration and size has a range.
      {"[limits]\nmax_request_seconds = 1e300\n", "limits.max_request_seconds"},
      {"[limits]\nmax_request_seconds = 0.0\n", "limits.max_request_seconds"},
      {"[limits]\nmax_request_seconds = inf\n", "limits.max_request_seconds"},
      {"[limits]\nmax_request_seconds = nan\n", "limits.max_request_seconds"},
      {"[limits]\nmax_body_bytes = 9223372036854775807\n", "limits.max_body_bytes"},
      {"[limits]\nmax_upload_bytes = 100\n", "limits.max_upload_bytes"},
      {"[limits]\nmax_samples = 100000\n", "limits.max_samples"},
      {"[server]\ndrain_timeout_s = 1e300\n", "server.drain_timeout_s"},
      {"[server]\nconnection_timeout_s = 2000000000\n", "server.connection_timeout_s"},
      {"[server]\nheader_timeout_s = 0.0\n", "server.header_timeout_s"},
      {"[server]\nheader_timeout_s = 1e18\n", "server.header_timeout_s"},
      {"[server]\nbody_grace_s = 1e300\n", "server.body_grace_s"},
      {"[server]\nmin_body_bytes_per_s = 0\n", "server.min_body_bytes_per_s"},
      {"[server]\nmax_connections = 0\n", "server.max_connections"},
      {"[server]\nmax_connections = 10\nmax_connections_per_peer = 11\n", "server.max_connections_per_peer"},
      {"[workers]\nqueue_depth = 100000000\n", "workers.queue_depth"},
      {"[workers]\nretry_after_s = 1000000\n", "workers.retry_after_s"},
      {"[workers]\nmemory_budget_bytes = 1000\n", "workers.memory_budget_bytes"},
      {"[sequences]\nmax_running = 0\n", "sequences.max_running"},
      {"[sequences]\nmax_running = 65\n", "sequences.max_running"},
      {"[sequences]\nmax_queued = -1\n", "sequences.max_queued"},
      {"[sequences]\nhistory = 0\n", "sequences.history"},
      {"[sequences]\nmax_runing = 2\n", "sequences.max_runing"},
  };
  for (const auto& [toml, key] : table) {
    const Error e = config_error(toml);
    EXPECT_EQ(e.field, key) << toml << " -> " << e.message;
    EXPECT_FALSE(e.message.empty()) << toml;
  }
  EXPECT_NE(config_error("[limits]\nmax_width = \"big\"\n").message.find("test.toml:2"), std::string::npos)
      << "errors name file:line";
  EXPECT_EQ(config_error("[limits\n").code, "config.invalid");
}

TEST(Config, SequencesKeysAreRead) {
  const Config d = parse_config("", "test.toml");
  EXPECT_EQ(d.sequences.max_running, 1);
  EXPECT_EQ(d.sequences.max_queued, 16);
  EXPECT_EQ(d.sequences.history, 100);
  const Config c = parse_config("[sequences]\nmax_running = 3\nmax_queued = 0\nhistory = 7\n", "test.toml");
  EXPECT_EQ(c.sequences.max_running, 3);
  EXPECT_EQ(c.sequences.max_queued, 0);
  EXPECT_EQ(c.sequences.history, 7);
  EXPECT_EQ(config_json(c)["sequences"]["history"], 7);
}

TEST(Config, RangeErrorsNameTheRange) {
  const Error e = config_error("[limits]\nmax_request_seconds = 1e300\n");
  EXPECT_EQ(e.code, "config.invalid");
  EXPECT_NE(e.message.find("outside [0.001, 86400]"), std::string::npos) << e.message;
}

TEST(Config, NewConnectionKeysAreRead) {
  const Config c = parse_config(R"(
[server]
max_connections = 512
max_connections_per_peer = 100
header_timeout_s = 2.5
body_grace_s = 1
min_body_bytes_per_s = 1000
[workers]
memory_budget_bytes = 1073741824
)", "t.toml");
  const ConnectionLimits l = connection_limits(c.server);
  EXPECT_EQ(l.max_connections, 512);
  EXPECT_EQ(l.max_connections_per_peer, 100);
  EXPECT_DOUBLE_EQ(l.header_timeout_s, 2.5);
  EXPECT_DOUBLE_EQ(l.body_grace_s, 1.0);
  EXPECT_EQ(l.min_body_bytes_per_s, 1000u);
  EXPECT_EQ(effective_memory_budget(c.workers), 1u << 30);
  EXPECT_GT(effective_memory_budget(WorkerConfig{}), 64u << 20) << "0 means half of the RAM";
}

// A dump directory that cannot be written is reported when the configuration is loaded.
TEST(Config, DumpDirectoryIsCheckedWhenLoaded) {
  testing::TempDir dir;
  Config c;
  c.source = "t.toml";
  c.paths.dump_dir = dir.path() / "new" / "dumps";
  EXPECT_NO_THROW(check_config_paths(c));
  EXPECT_TRUE(std::filesystem::is_directory(c.paths.dump_dir)) << "created";
  EXPECT_TRUE(std::filesystem::is_empty(c.paths.dump_dir)) << "the write test leaves nothing behind";
  std::ofstream(dir.path() / "file") << "x";
  c.paths.dump_dir = dir.path() / "file";
  try {
    check_config_paths(c);
    ADD_FAILURE() << "a file as dump directory was accepted";
  } catch (const HdrdError& e) {
    EXPECT_EQ(e.error().field, "paths.dump_dir");
  }
  c.paths.dump_dir = "/proc/hdrd-no-such-dir/dumps";  // /proc takes no new directories, even from root
  EXPECT_THROW(check_config_paths(c), HdrdError);
  c.paths.dump_dir.clear();
  c.paths.asset_root = dir.path() / "missing";
  EXPECT_THROW(check_config_paths(c), HdrdError);
}

TEST(Config, DefaultSocketFollowsXdgRuntimeDir) {
  const char* old = std::getenv("XDG_RUNTIME_DIR");
  const std::string saved = old ? old : "";
  ::setenv("XDG_RUNTIME_DIR", "/run/user/1234", 1);
  EXPECT_EQ(default_socket_path(), "/run/user/1234/hdrd.sock");
  ::unsetenv("XDG_RUNTIME_DIR");
  EXPECT_EQ(default_socket_path(), "/run/hdrd/hdrd.sock");
  if (old) ::setenv("XDG_RUNTIME_DIR", saved.c_str(), 1);
}

// sd_listen_fds(3): only when LISTEN_PID is this process; the variables are then unset.
TEST(Config, SystemdListenFdsSemantics) {
  ::setenv("LISTEN_PID", "1", 1);  // someone else's
  ::setenv("LISTEN_FDS", "1", 1);
  EXPECT_TRUE(systemd_listen_fds().empty());
  EXPECT_EQ(std::getenv("LISTEN_FDS"), nullptr) << "unset so children do not inherit them";
  ::setenv("LISTEN_PID", std::to_string(::getpid()).c_str(), 1);
  ::setenv("LISTEN_FDS", "2", 1);
  EXPECT_EQ(systemd_listen_fds(), (std::vector<int>{3, 4}));
  ::setenv("LISTEN_PID", std::to_string(::getpid()).c_str(), 1);
  ::setenv("LISTEN_FDS", "x", 1);
  EXPECT_TRUE(systemd_listen_fds().empty());
}

TEST(Config, UnixListenerRefusesToReplaceALiveSocketOrAFile) {
  testing::TempDir tmp;
  const auto path = tmp / "d/hdrd.sock";
  {
    Listener l = listen_unix(path, 0660, "");
    EXPECT_GE(l.fd(), 0);
    EXPECT_THROW(listen_unix(path, 0660, ""), HdrdError) << "a live daemon owns it";
  }
  EXPECT_FALSE(std::filesystem::exists(path)) << "removed on close";
  std::ofstream(tmp / "file") << "x";
  EXPECT_THROW(listen_unix(tmp / "file", 0660, ""), HdrdError);
  EXPECT_THROW(listen_tcp("0.0.0.0:0", false), HdrdError) << "non-loopback refused";
  EXPECT_NO_THROW(listen_tcp("127.0.0.1:0", false));
}

}  // namespace
}  // namespace hdrd::daemon
