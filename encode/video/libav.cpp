#include "encode/video/libav.hpp"

#include <dlfcn.h>

#include <atomic>
#include <mutex>
#include <string>

#include <fmt/format.h>

namespace hdrd::video::lav {
namespace {

#define HDRD_STR2(x) #x
#define HDRD_STR(x) HDRD_STR2(x)
constexpr const char* kLibraries[] = {
    "libavutil.so." HDRD_STR(LIBAVUTIL_VERSION_MAJOR),
    "libavcodec.so." HDRD_STR(LIBAVCODEC_VERSION_MAJOR),
    "libavformat.so." HDRD_STR(LIBAVFORMAT_VERSION_MAJOR),
};
#undef HDRD_STR
#undef HDRD_STR2

Functions g_table;
std::once_flag g_once;
Error g_error;
std::atomic<bool> g_loaded{false};
std::atomic<bool> g_quiet{false};

void load_once() {
  void* handles[std::size(kLibraries)] = {};
  for (std::size_t i = 0; i < std::size(kLibraries); ++i) {
    // Kept open for the process: the codecs may keep threads and state until exit.
    handles[i] = ::dlopen(kLibraries[i], RTLD_NOW | RTLD_LOCAL);
    if (!handles[i]) {
      const char* why = ::dlerror();
      g_error = make_error("video.libav", fmt::format("video output needs FFmpeg's {}: {}", kLibraries[i],
                                                      why ? why : "not found"));
      return;
    }
  }
  // Each name is looked up in the last library and what it links (libavformat links the other two).
  void* all = handles[std::size(kLibraries) - 1];
  std::string missing;
#define HDRD_LIBAV_RESOLVE(name)                                                    \
  g_table.name = reinterpret_cast<decltype(g_table.name)>(::dlsym(all, #name));     \
  if (!g_table.name) missing += std::string(missing.empty() ? "" : ", ") + #name;
  HDRD_LIBAV_FUNCTIONS(HDRD_LIBAV_RESOLVE)
#undef HDRD_LIBAV_RESOLVE
  if (!missing.empty()) {
    g_error = make_error("video.libav", "FFmpeg's libraries lack " + missing);
    return;
  }
  g_loaded = true;
  if (g_quiet.load()) g_table.av_log_set_level(AV_LOG_ERROR);
}

}  // namespace

Result<void> load() {
  std::call_once(g_once, load_once);
  if (!g_loaded) return g_error;
  return {};
}

const Functions& table() { return g_table; }

void quiet_logs() {
  g_quiet = true;
  if (g_loaded) g_table.av_log_set_level(AV_LOG_ERROR);
}

}  // namespace hdrd::video::lav
