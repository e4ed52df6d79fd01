// hdrctl: the command-line client of `hdrd serve`. Subcommands mirror the API
// (docs/api.md): render, encode, pattern, selftest, sequence, jobs, displays,
// capabilities, status, metrics. The request options and bodies are in options.cpp.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <optional>
#include <sstream>
#include <thread>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "clients/cpp/client.hpp"
#include "encode/display_target.hpp"
#include "tools/common/cli_docs.hpp"
#include "tools/common/progress_bar.hpp"
#include "tools/hdrctl/options.hpp"

namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using hdrd::daemon::Client;
using hdrd::daemon::ClientOptions;
using hdrd::daemon::ClientResponse;
using namespace hdrctl;

// Options of hdrctl itself; they may come before or after the subcommand.
struct Global {
  std::string socket = hdrd::daemon::default_client_socket();
  std::string tcp, token_file;
  double timeout_s = 300;
  bool json = false;
  bool quiet = false;
};

struct EncodeOptions {
  FrameOptions frame;
  std::string input;
};

struct PatternOptions {
  FrameOptions frame;
  std::string name;
  bool list = false;
};

struct SelftestOptions {
  std::string mode = "hdr10";
  std::optional<double> peak;
  bool no_render = false;
  bool failed_only = false;
};

Client make_client(const Global& g) {
  ClientOptions co;
  co.socket_path = g.socket;
  co.tcp = g.tcp;
  co.timeout_s = g.timeout_s;
  if (!g.token_file.empty()) {
    std::string t = read_all(g.token_file);
    while (!t.empty() && (t.back() == '\n' || t.back() == '\r' || t.back() == ' ')) t.pop_back();
    co.token = t;
  }
  if (!g.quiet) {
    const bool tty = ::isatty(STDERR_FILENO);
    co.on_wait = [tty, last = 0](double s) mutable {
      if (s < 1.0 || int(s) == last) return;
      last = int(s);
      std::fprintf(stderr, tty ? "\rhdrctl: waiting for the daemon... %d s" : "hdrctl: waiting for the daemon... %d s\n",
                   last);
      std::fflush(stderr);
    };
  }
  return Client(co);
}

ClientResponse call(const Global& g, const std::string& method, const std::string& target, const std::string& body = {},
                    const std::vector<std::pair<std::string, std::string>>& headers = {}) {
  Client client = make_client(g);
  auto r = client.request(method, target, body, headers);
  if (!g.quiet && ::isatty(STDERR_FILENO)) std::fputs("\r\033[K", stderr);
  if (!r) throw Failure{3, r.error().message};
  if (r->status >= 400) {
    const auto e = r->error();
    if (g.json) std::fwrite(r->body.data(), 1, r->body.size(), stdout);
    throw Failure{1, fmt::format("{} ({}){}", e.message, e.code, e.field.empty() ? "" : ", field " + e.field)};
  }
  return std::move(*r);
}

void print(const std::string& s) {
  std::fwrite(s.data(), 1, s.size(), stdout);
  if (s.empty() || s.back() != '\n') std::fputc('\n', stdout);
}

// A regular file is replaced atomically (no reader sees half a frame): written to a
// temporary beside it, renamed by commit(), removed if never committed. A device or FIFO
// (-o /dev/null, a pipe) is written directly.
class AtomicFile {
 public:
  explicit AtomicFile(std::string path) : path_(std::move(path)) {
    std::error_code ec;
    const fs::path p(path_);
    direct_ = fs::exists(p, ec) && !fs::is_regular_file(p, ec);
    if (!direct_) {
      tmp_ = p;
      tmp_ += fmt::format(".tmp-{}", ::getpid());
    }
    out_.open(direct_ ? p : tmp_, std::ios::binary | std::ios::trunc);
    if (!out_) fail("cannot write " + path_);
  }
  ~AtomicFile() {
    if (!committed_ && !direct_) {
      std::error_code ec;
      out_.close();
      fs::remove(tmp_, ec);
    }
  }
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  void write(std::string_view data) {
    if (!out_.write(data.data(), std::streamsize(data.size()))) fail("cannot write " + path_);
    bytes_ += data.size();
  }
  void commit() {
    if (!out_.flush()) fail("cannot write " + path_);
    out_.close();
    committed_ = true;
    if (direct_) return;
    std::error_code ec;
    fs::rename(tmp_, path_, ec);
    if (ec) {
      const std::string why = ec.message();
      fs::remove(tmp_, ec);
      throw Failure{1, "cannot write " + path_ + ": " + why};
    }
  }
  std::uint64_t bytes() const { return bytes_; }

 private:
  [[noreturn]] void fail(const std::string& why) { throw Failure{1, why}; }
  std::string path_;
  fs::path tmp_;
  std::ofstream out_;
  bool direct_ = false, committed_ = false;
  std::uint64_t bytes_ = 0;
};

void write_atomically(const std::string& path, const std::string& data) {
  AtomicFile f(path);
  f.write(data);
  f.commit();
}

// The X-Hdrd-* headers as a JSON object (keys without the prefix).
json frame_metadata(const ClientResponse& r) {
  json meta = json::object();
  for (const auto& [k, v] : r.headers)
    if (k.rfind("x-hdrd-", 0) == 0) meta[k.substr(7)] = v;
  meta["content_type"] = r.header("content-type") ? *r.header("content-type") : "";
  meta["bytes"] = r.body.size();
  return meta;
}

std::string summary_line(const json& meta, const std::string& destination) {
  auto get = [&](const char* k) { return meta.value(k, std::string("?")); };
  auto optional_ms = [&](const char* k, const char* what) {
    return meta.contains(k) ? fmt::format(", {} {} ms", what, get(k)) : std::string();
  };
  return fmt::format("{}{} {}x{} {} {} MaxCLL {} MaxFALL {} -> {} ({} bytes{}{})",
                     meta.contains("pattern") ? get("pattern") + " " : "", get("mode"), get("width"), get("height"),
                     get("fourcc"), meta["content_type"].get<std::string>(), get("maxcll"), get("maxfall"), destination,
                     meta["bytes"].get<std::size_t>(), optional_ms("render-ms", "render"),
                     optional_ms("encode-ms", "encode"));
}

// Writes the frame (or prints the dump's sidecar) and a summary of the X-Hdrd-* metadata:
// on stderr, or as JSON on stdout with --json.
void finish_frame(const Global& g, const OutputOptions& o, const ClientResponse& r) {
  if (o.dump) {
    print(r.body);
    return;
  }
  json meta = frame_metadata(r);
  const bool to_stdout = o.output.empty() || o.output == "-";
  if (!to_stdout) {
    write_atomically(o.output, r.body);
    meta["output"] = o.output;
  } else if (o.output.empty() && ::isatty(STDOUT_FILENO)) {
    throw Failure{2, "refusing to write an image to a terminal: use -o FILE (or -o - to force stdout)"};
  } else {
    std::fwrite(r.body.data(), 1, r.body.size(), stdout);
  }
  if (g.json && !to_stdout) print(meta.dump(2));
  else if (!g.quiet) std::fprintf(stderr, "hdrctl: %s\n", summary_line(meta, to_stdout ? "stdout" : o.output).c_str());
}

void run_render(const Global& g, const FrameOptions& o) {
  const json b = frame_body(o);
  const auto r = call(g, "POST", "/v1/render", b.dump(),
                      {{"Content-Type", "application/json"}, {"Accept", accept_for(o.out)}});
  finish_frame(g, o.out, r);
}

void run_encode(const Global& g, const EncodeOptions& o) {
  const json b = frame_body(o.frame);
  std::string content_type;
  const std::string body = hdrd::daemon::multipart_body(
      {{"image", fs::path(o.input).filename().string(), "image/x-exr", read_all(o.input)},
       {"request", "", "application/json", b.dump()}},
      &content_type);
  const auto r =
      call(g, "POST", "/v1/encode", body, {{"Content-Type", content_type}, {"Accept", accept_for(o.frame.out)}});
  finish_frame(g, o.frame.out, r);
}

// hdrctl pattern --list: the patterns and their parameters, from GET /v1/capabilities.
void print_pattern_list(const Global& g) {
  const json caps = json::parse(call(g, "GET", "/v1/capabilities").body, nullptr, false);
  if (!caps.is_object() || !caps.contains("patterns")) throw Failure{1, "the daemon does not list patterns"};
  if (g.json) return print(caps["patterns"].dump(2));
  std::string s;
  for (const auto& p : caps["patterns"]) {
    s += fmt::format("{:11} {}\n", p.value("name", ""), p.value("description", ""));
    for (const auto& q : p["params"]) {
      const std::string range = q.contains("min") ? fmt::format(" [{}, {}]", q["min"].dump(), q["max"].dump()) : "";
      const std::string def = q["default"].is_null() ? q.value("default_from", "") : q["default"].dump();
      s += fmt::format("{:11}   params.{} ({}{}, default {}): {}\n", "", q.value("name", ""), q.value("type", ""),
                       range, def, q.value("description", ""));
    }
  }
  print(s);
}

void run_pattern(const Global& g, const PatternOptions& o) {
  if (o.list) return print_pattern_list(g);
  if (o.name.empty()) throw Failure{2, "a pattern name is required (hdrctl pattern --list shows them)"};
  const json b = frame_body(o.frame, {{"pattern", o.name}});
  const auto r = call(g, "POST", "/v1/pattern", b.dump(),
                      {{"Content-Type", "application/json"}, {"Accept", accept_for(o.frame.out)}});
  finish_frame(g, o.frame.out, r);
}

std::string selftest_text(const json& report, bool failed_only) {
  std::string s = fmt::format("selftest {} (peak {} cd/m2, paper white {} cd/m2): {} checks, {} failed, {:.1f} s\n",
                              report.value("mode", "?"), report.value("peak_nits", 0.0),
                              report.value("paper_white_nits", 0.0), report["checks"].size(), report.value("failed", 0),
                              report.value("seconds", 0.0));
  for (const auto& c : report["checks"]) {
    const bool passed = c.value("passed", false), skipped = c.value("skipped", false);
    if (failed_only && (passed || skipped)) continue;
    s += fmt::format("  {} {:34} {}  [{}]\n", skipped ? "SKIP" : (passed ? "ok  " : "FAIL"), c.value("name", ""),
                     c.value("detail", ""), c.value("source", ""));
  }
  return s;
}

// Exit status 1 when a check failed (the report is the output; no extra error line).
int run_selftest(const Global& g, const SelftestOptions& o) {
  json b = {{"mode", o.mode}};
  if (o.peak) b["peak_nits"] = *o.peak;
  if (o.no_render) b["render"] = false;
  const auto r = call(g, "POST", "/v1/selftest", b.dump(), {{"Content-Type", "application/json"}});
  const json report = json::parse(r.body, nullptr, false);
  if (!report.is_object() || !report.contains("checks")) throw Failure{1, "the daemon's selftest answer is not a report"};
  print(g.json ? report.dump(2) : selftest_text(report, o.failed_only));
  return report.value("passed", false) ? 0 : 1;
}

// One Prometheus text-format sample line: name{k="v",...} value.
json prometheus_sample(const std::string& line) {
  const auto brace = line.find('{'), space = line.rfind(' ');
  if (space == std::string::npos) return nullptr;
  json j = {{"name", line.substr(0, std::min(brace, space))}, {"labels", json::object()}};
  if (brace != std::string::npos && brace < space) {
    const std::string labels = line.substr(brace + 1, line.rfind('}', space) - brace - 1);
    for (std::size_t pos = 0; pos < labels.size();) {
      const auto eq = labels.find("=\"", pos), end = labels.find('"', eq + 2);
      if (eq == std::string::npos || end == std::string::npos) break;
      j["labels"][labels.substr(pos, eq - pos)] = labels.substr(eq + 2, end - eq - 2);
      pos = end + 2;  // past the quote and the comma
    }
  }
  const std::string value = line.substr(space + 1);
  j["value"] = value == "+Inf" ? json("+Inf") : json(std::strtod(value.c_str(), nullptr));
  return j;
}

// GET /metrics as JSON: {"samples": [{"name", "labels", "value"}], "types": {name: type}}.
json prometheus_to_json(const std::string& text) {
  json out = {{"samples", json::array()}, {"types", json::object()}};
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("# TYPE ", 0) == 0) {
      std::istringstream t(line.substr(7));
      std::string name, type;
      t >> name >> type;
      out["types"][name] = type;
    } else if (!line.empty() && line[0] != '#') {
      if (json sample = prometheus_sample(line); !sample.is_null()) out["samples"].push_back(std::move(sample));
    }
  }
  return out;
}

// Pretty GET answers; --json prints JSON bodies as they came (metrics: converted), and a
// text endpoint without --json prints its text.
void run_get(const Global& g, const std::string& path, bool text) {
  const auto r = call(g, "GET", path);
  if (text) {
    print(g.json ? prometheus_to_json(r.body).dump(2) : r.body);
    return;
  }
  if (g.json) {
    print(r.body);
    return;
  }
  json j = json::parse(r.body, nullptr, false);
  if (j.is_discarded()) {
    print(r.body);
    return;
  }
  if (path == "/v1/status") {
    print(fmt::format("hdrd {} up {:.0f} s on {}", j.value("version", "?"), j.value("uptime_s", 0.0),
                      j["listeners"].dump()));
    if (j.contains("renderer"))
      print(fmt::format("renderer: {}", j["renderer"].value("available", false)
                                            ? j["renderer"].value("backend", "") + " (" + j["renderer"].value("gl_renderer", "") + ")"
                                            : "not available"));
    if (j.contains("queue"))
      print(fmt::format("queue: {} waiting, {} running, capacity {}", j["queue"].value("depth", 0),
                        j["queue"].value("running", 0), j["queue"].value("capacity", 0)));
    return;
  }
  print(j.dump(2));
}

// ---- sequences and jobs (POST /v1/sequences, /v1/jobs) ---------------------------------

struct JobsOptions {
  std::string action = "list";  // list, show, cancel, wait, result
  std::string id;
  std::string output;
  bool keep = false;  // leave the job's files in the dump directory after downloading
};

json get_job(const Global& g, const std::string& id) {
  json j = json::parse(call(g, "GET", "/v1/jobs/" + id).body, nullptr, false);
  if (!j.is_object() || !j.contains("state")) throw Failure{1, "the daemon's answer for job " + id + " is not a job"};
  return j;
}

std::string job_line(const json& j) {
  std::string s = fmt::format("{}  {:9} {:>6}/{:<6} {:6.1f} fps  {}  {}", j.value("id", "?"), j.value("state", "?"),
                              j.value("frames_done", 0), j.value("frames_total", 0), j.value("fps", 0.0),
                              j.value("source", ""), j.value("name", ""));
  if (j.contains("error")) s += "  (" + j["error"].value("code", "") + ": " + j["error"].value("message", "") + ")";
  return s;
}

// Polls until the job is final, with the progress bar (frames, fps, time left) on stderr.
json follow_job(const Global& g, const std::string& id, double poll_s) {
  hdrd::cli::ProgressBar bar("hdrctl:", !g.quiet);
  for (;;) {
    json j = get_job(g, id);
    const std::string state = j.value("state", "");
    bar.update(j.value("frames_done", 0), j.value("frames_total", 0), j.value("fps", 0.0), j.value("eta_s", 0.0));
    if (state == "done" || state == "failed" || state == "cancelled") {
      bar.finish();
      return j;
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(poll_s));
  }
}

// Streams the result into the file as it arrives (a video is never held in memory).
void download_result(const Global& g, const std::string& id, const std::string& output) {
  Client client = make_client(g);
  AtomicFile file(output);
  auto r = client.download("/v1/jobs/" + id + "/result", [&](std::string_view piece) -> hdrd::Result<void> {
    file.write(piece);
    return {};
  });
  if (!r) throw Failure{3, r.error().message};
  if (r->status >= 400) {
    const auto e = r->error();
    throw Failure{1, fmt::format("{} ({}){}", e.message, e.code, e.field.empty() ? "" : ", field " + e.field)};
  }
  file.commit();
  if (!g.quiet)
    std::fprintf(stderr, "hdrctl: wrote %s (%s, %llu bytes)\n", output.c_str(),
                 r->header("content-type") ? r->header("content-type")->c_str() : "?",
                 static_cast<unsigned long long>(file.bytes()));
}

// Once the result is downloaded, the job's files in the daemon's dump directory (the video,
// the sidecar, the per-frame dumps) are a copy nobody asked to keep: DELETE removes them,
// so downloads do not pile up there. --keep leaves them.
void remove_job_files(const Global& g, const std::string& id) {
  const json j = json::parse(call(g, "DELETE", "/v1/jobs/" + id).body, nullptr, false);
  if (!g.quiet && j.value("files_removed", false))
    std::fprintf(stderr, "hdrctl: removed job %s's files from the daemon's dump directory (--keep keeps them)\n",
                 id.c_str());
}

void download_and_tidy(const Global& g, const std::string& id, const std::string& output, bool keep) {
  download_result(g, id, output);
  if (!keep) remove_job_files(g, id);
}

// A final job: its JSON (--json) or a summary; failed and cancelled jobs exit 1.
void finish_job(const Global& g, json j, const std::string& output, bool keep) {
  const std::string state = j.value("state", "");
  if (state != "done") {
    if (g.json) print(j.dump(2));
    const std::string why = j.contains("error") ? fmt::format("{} ({})", j["error"].value("message", ""), j["error"].value("code", ""))
                                                : std::string("no reason given");
    throw Failure{1, fmt::format("job {} {}: {}", j.value("id", ""), state, why)};
  }
  if (!output.empty()) {
    download_and_tidy(g, j.value("id", ""), output, keep);
    if (!keep) j = get_job(g, j.value("id", ""));  // files and files_removed as they are now
  }
  if (g.json) return print(j.dump(2));
  std::string s = fmt::format("job {} done: {} frames in {:.1f} s ({:.1f} fps)\n", j.value("id", ""),
                              j.value("frames_done", 0), j.value("elapsed_s", 0.0), j.value("fps", 0.0));
  for (const auto& [kind, path] : j["files"].items()) s += fmt::format("  {:14} {}\n", kind, path.get<std::string>());
  if (!output.empty()) s += fmt::format("  {:14} {}\n", "downloaded", output);
  print(s);
}

void run_sequence(const Global& g, const SequenceOptions& o) {
  const json b = sequence_body(o);
  const auto r = call(g, "POST", "/v1/sequences", b.dump(), {{"Content-Type", "application/json"}});
  const json accepted = json::parse(r.body, nullptr, false);
  if (!accepted.is_object() || !accepted.contains("id")) throw Failure{1, "the daemon's answer is not a job"};
  const std::string id = accepted["id"];
  if (o.detach) return print(g.json ? accepted.dump(2) : id);
  if (!g.quiet)
    std::fprintf(stderr, "hdrctl: job %s, %d frames (it goes on if hdrctl stops: hdrctl jobs cancel %s)\n", id.c_str(),
                 accepted.value("frames_total", 0), id.c_str());
  finish_job(g, follow_job(g, id, o.poll_s), o.output, o.keep);
}

void run_jobs(const Global& g, const JobsOptions& o) {
  if (o.action == "list") {
    const json j = json::parse(call(g, "GET", "/v1/jobs").body, nullptr, false);
    if (g.json || !j.contains("jobs")) return print(j.dump(2));
    std::string s = fmt::format("{} queued, {} running, {} finished\n", j.value("queued", 0), j.value("running", 0),
                                j.value("finished", 0));
    for (const auto& job : j["jobs"]) s += job_line(job) + "\n";
    return print(s);
  }
  if (o.id.empty()) throw Failure{2, "hdrctl jobs " + o.action + " needs a job id"};
  if (o.action == "show") {
    const json j = get_job(g, o.id);
    return print(g.json ? j.dump(2) : job_line(j));
  }
  if (o.action == "cancel") {
    const json j = json::parse(call(g, "DELETE", "/v1/jobs/" + o.id).body, nullptr, false);
    return print(g.json ? j.dump(2) : job_line(j));
  }
  if (o.action == "wait") return finish_job(g, follow_job(g, o.id, 0.25), o.output, o.keep);
  if (o.action == "result") {
    if (o.output.empty()) throw Failure{2, "hdrctl jobs result ID needs -o FILE"};
    return download_and_tidy(g, o.id, o.output, o.keep);
  }
  throw Failure{2, "hdrctl jobs: unknown action '" + o.action + "' (list, show, cancel, wait, result)"};
}

void add_global_options(CLI::App& app, Global& g) {
  app.add_option("--socket", g.socket, "Daemon socket (default: $HDRD_SOCKET, $XDG_RUNTIME_DIR/hdrd.sock)");
  app.add_option("--tcp", g.tcp, "Connect over TCP host:port instead (needs --token-file)");
  app.add_option("--token-file", g.token_file, "Bearer token for TCP");
  app.add_option("--timeout", g.timeout_s, "Seconds to wait for an answer");
  app.add_flag("--json", g.json, "Machine-readable output on stdout");
  app.add_flag("-q,--quiet", g.quiet, "No progress on stderr");
  // Options of hdrctl itself may follow the subcommand too (hdrctl status --json).
  app.fallthrough();
}

constexpr const char* kGlobalNote =
    "\nhdrctl's own options (--socket, --tcp, --token-file, --timeout, --json, -q) may also be given here.\n"
    "While a request takes longer than a second, hdrctl shows \"waiting for the daemon... N s\" on stderr.";

// The display modes, as every --mode names them (hdrd selftest's patterns::suite_modes_text).
std::string selftest_mode_help() {
  std::string s;
  for (auto m : hdrd::mode_names()) s += (s.empty() ? "" : ", ") + std::string(m);
  return "Display mode: " + s;
}

std::string examples(std::initializer_list<const char*> lines) {
  std::string s = "Examples:\n";
  for (const char* l : lines) s += std::string("  ") + l + "\n";
  return s + kGlobalNote;
}

int print_docs(const CLI::App& app, const std::string& what) {
  hdrd::cli::ManPage page{.name = "hdrctl", .section = 1, .version = "hdrd " HDRD_VERSION_STRING,
                          .summary = "client of the hdrd daemon"};
  page.sections = {
      {"Environment", "HDRD_SOCKET: the daemon's socket when --socket is not given; else "
                      "$XDG_RUNTIME_DIR/hdrd.sock, else /run/hdrd/hdrd.sock (the system service's: members of "
                      "the hdrd group may connect)."},
      {"Exit status", "0 ok, 1 an error answer (or a failed selftest), 2 a usage error, 3 the daemon cannot be reached."},
  };
  page.see_also = {"hdrd(1)", "hdrd.toml(5)"};
  if (what == "man") std::cout << hdrd::cli::man_page(app, page);
  else if (what == "bash-completion") std::cout << hdrd::cli::bash_completion(app);
  else throw Failure{2, "hdrctl docs: unknown page '" + what + "' (man, bash-completion)"};
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hdrctl: client for the hdrd daemon (HTTP over its Unix socket; see docs/api.md)", "hdrctl"};
  app.require_subcommand(1);
  Global g;
  add_global_options(app, g);
  app.footer(
      "Examples:\n"
      "  hdrctl status\n"
      "  hdrctl render --width 256 --height 144 --mode hdr10 --peak 1000 -o frame.png\n"
      "  hdrctl render --scene material-grid --mode scrgb -o frame.exr\n"
      "  hdrctl render --mode sdr --dump --name grid\n"
      "  hdrctl encode ../shared/fixtures/exr/Desk.exr --mode sdr -o desk.png\n"
      "  hdrctl pattern bt2111 --mode hlg -o bars.png\n"
      "  hdrctl selftest --mode hdr10 --peak 1000\n"
      "  hdrctl sequence render --scene hdr --frames 48 --video hevc -o walk.mp4\n"
      "  hdrctl jobs\n"
      "  hdrctl capabilities --json | jq '.tone_curves[].name'\n"
      "  hdrctl metrics\n"
      "Every subcommand has --help with its own examples. Exit status: 0 ok, 1 an error answer (or a failed\n"
      "selftest), 2 a usage error, 3 the daemon cannot be reached.");

  FrameOptions ro;
  auto* render = app.add_subcommand("render", "POST /v1/render: render a scene and fetch the encoded frame");
  add_frame_options(render, hdrd::job::Source::render, ro);
  render->footer(examples({"hdrctl render --width 256 --height 144 --mode hdr10 --peak 1000 -o frame.png",
                           "hdrctl render --mode scrgb -o frame.exr                  (format from the extension)",
                           "hdrctl render --scene model.gltf --camera 0,1.5,4:0,0.5,0:40 -o m.png   (files: the asset root)",
                           "hdrctl render --request req.json --set display.mode=sdr -o frame.png",
                           "hdrctl render --mode sdr --dump --name grid             (prints the sidecar)",
                           "hdrctl render --width 64 --height 36 -o f.png --json    (metadata as JSON)",
                           "The request options are hdrd render's (docs/settings.md), with the same defaults."}));

  EncodeOptions eo;
  auto* encode = app.add_subcommand("encode", "POST /v1/encode: encode a local OpenEXR through the daemon");
  encode->add_option("file", eo.input, "OpenEXR file")->required();
  add_frame_options(encode, hdrd::job::Source::encode, eo.frame);
  encode->footer(examples({"hdrctl encode Desk.exr --mode hdr10 --peak 600 -o desk.png",
                           "hdrctl encode Desk.exr --mode scrgb --tonemap bt2390 -o desk.exr",
                           "hdrctl encode Desk.exr --mode sdr --dump --format png,raw --name desk",
                           "The request options are hdrd encode's (docs/settings.md), with the same defaults."}));

  PatternOptions po;
  auto* pattern = app.add_subcommand("pattern", "POST /v1/pattern: a standard HDR test pattern for a display mode");
  pattern->add_option("name", po.name, "bt2111, pq-ramp, window, near-black, clipping, sdr-grey (--list)");
  pattern->add_flag("--list", po.list, "List the patterns and their parameters (from the daemon)");
  add_frame_options(pattern, hdrd::job::Source::pattern, po.frame);
  pattern->footer(examples({"hdrctl pattern --list",
                            "hdrctl pattern bt2111 --mode hdr10 -o bars-pq.png       (ITU-R BT.2111-2, narrow range)",
                            "hdrctl pattern window --mode hdr10 --peak 1000 --level 1000 --area 10 -o win.png",
                            "hdrctl pattern pq-ramp --steps 21 --width 1920 --height 200 -o ramp.png",
                            "hdrctl pattern clipping --mode hdr10 --peak 10000 --level 1000 --dump --name clip",
                            "hdrctl pattern window --mode scrgb -o win.exr --json"}));

  SelftestOptions so;
  auto* selftest = app.add_subcommand("selftest", "POST /v1/selftest: the daemon's display-mode suite for one mode");
  selftest->add_option("--mode", so.mode, selftest_mode_help())->capture_default_str();
  selftest->add_option("--peak", so.peak, "Display peak luminance, cd/m2 (default: the mode's)");
  selftest->add_flag("--no-render", so.no_render, "Skip the rendered built-in scenes");
  selftest->add_flag("--failed", so.failed_only, "Print only failed checks (text output)");
  selftest->footer(examples({"hdrctl selftest --mode hdr10 --peak 1000",
                             "hdrctl selftest --mode hlg --json | jq '.checks[] | select(.passed == false)'",
                             "hdrctl selftest --mode sdr-bt1886 --failed",
                             "Exit status 1 when a check fails (the daemon still answers 200: docs/api.md)."}));

  auto* sequence = app.add_subcommand("sequence", "POST /v1/sequences: render or encode a sequence as a job, follow it");
  sequence->require_subcommand(1);
  SequenceOptions sro, seo;
  sro.source = hdrd::job::Source::render;
  seo.source = hdrd::job::Source::encode;
  auto* seq_render = sequence->add_subcommand("render", "Render a sequence of frames (the scene's time axis)");
  add_sequence_options(seq_render, sro);
  auto* seq_encode = sequence->add_subcommand("encode", "Encode an EXR sequence from the daemon's asset root");
  seq_encode->add_option("images", seo.images, "A frame pattern (shot/shot.%04d.exr), a directory or a list file, "
                                               "in the daemon's asset root")->required();
  add_sequence_options(seq_encode, seo);
  sequence->footer(examples({"hdrctl sequence render --scene hdr --frames 144 --fps 24 --video hevc -o walk.mp4",
                             "hdrctl sequence encode 'shots/a.%04d.exr' --mode hdr10 --video hevc --name a -o a.mp4",
                             "hdrctl sequence render --frames 48 --format png --detach        (prints the job id)",
                             "The options are hdrd render/encode's (docs/settings.md, sequence settings included);",
                             "the files go into the daemon's dump directory; -o downloads the video (else the sidecar)."}));

  JobsOptions jo;
  auto* jobs = app.add_subcommand("jobs", "GET/DELETE /v1/jobs: list, show, cancel, wait for or fetch sequence jobs");
  jobs->add_option("action", jo.action, "list (default), show ID, cancel ID, wait ID, result ID -o FILE");
  jobs->add_option("id", jo.id, "The job's id");
  jobs->add_option("-o,--output", jo.output, "wait/result: download the result here (then remove the job's files)");
  jobs->add_flag("--keep", jo.keep, "With -o: keep the job's files in the daemon's dump directory after downloading");
  jobs->footer(examples({"hdrctl jobs", "hdrctl jobs show 3f2a9c0d1e4b5a67 --json", "hdrctl jobs cancel 3f2a9c0d1e4b5a67",
                         "hdrctl jobs wait 3f2a9c0d1e4b5a67 -o walk.mp4"}));

  auto* displays = app.add_subcommand("displays", "GET /v1/displays: attached displays and their HDR capabilities");
  auto* caps = app.add_subcommand("capabilities", "GET /v1/capabilities: modes, tone curves, patterns, limits");
  auto* status = app.add_subcommand("status", "GET /v1/status: version, uptime, renderer, queue");
  auto* metrics = app.add_subcommand("metrics", "GET /metrics: Prometheus text");
  displays->footer(examples({"hdrctl displays", "hdrctl displays --json | jq '.auto'"}));
  caps->footer(examples({"hdrctl capabilities", "hdrctl capabilities --json | jq '.patterns[].name'"}));
  status->footer(examples({"hdrctl status", "hdrctl status --json | jq .queue"}));
  metrics->footer(examples({"hdrctl metrics | grep hdrd_requests_total",
                            "hdrctl metrics --json | jq '.samples[] | select(.name == \"hdrd_queue_depth\")'"}));

  // Hidden: hdrctl(1) and the bash completion, written from these options (cmake/Docs.cmake).
  std::string docs_what;
  auto* docs = app.add_subcommand("docs", "Write hdrctl(1) or hdrctl's bash completion to stdout");
  docs->add_option("what", docs_what, "man or bash-completion")->required();
  docs->group("");

  try {
    app.parse(argc, argv);
    if (*docs) return print_docs(app, docs_what);
    if (*render) run_render(g, ro);
    else if (*encode) run_encode(g, eo);
    else if (*pattern) run_pattern(g, po);
    else if (*selftest) return run_selftest(g, so);
    else if (*seq_render) run_sequence(g, sro);
    else if (*seq_encode) run_sequence(g, seo);
    else if (*jobs) run_jobs(g, jo);
    else if (*displays) run_get(g, "/v1/displays", false);
    else if (*caps) run_get(g, "/v1/capabilities", false);
    else if (*status) run_get(g, "/v1/status", false);
    else if (*metrics) run_get(g, "/metrics", true);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const Failure& f) {
    std::fprintf(stderr, "hdrctl: error: %s\n", f.message.c_str());
    return f.exit_code;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "hdrctl: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
