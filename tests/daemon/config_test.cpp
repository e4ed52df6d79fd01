// config/hdrd.toml: the shipped file parses and states the built-in defaults; unknown
// keys, wrong types and unsafe values are refused with file:line and the key.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "daemon/config.hpp"
#include "daemon/listener.hpp"
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
