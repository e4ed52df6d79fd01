#include "tools/common/progress_bar.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <fmt/format.h>

namespace hdrd::cli {

std::string duration_text(double seconds) {
  const long long s = std::isfinite(seconds) ? std::max(0LL, std::llround(seconds)) : 0;
  if (s >= 3600) return fmt::format("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60);
  return fmt::format("{}:{:02}", s / 60, s % 60);
}

ProgressBar::ProgressBar(std::string label, bool enabled)
    : label_(std::move(label)), enabled_(enabled), tty_(::isatty(STDERR_FILENO) == 1) {}

ProgressBar::~ProgressBar() { finish(); }

void ProgressBar::update(int done, int total, double rate, double eta_s) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  const bool last = total > 0 && done >= total;
  // A terminal redraws at most 10 times a second; a log gets a line every 5 s and the last.
  const auto every = tty_ ? std::chrono::milliseconds(100) : std::chrono::milliseconds(5000);
  if (!last && drawn_ && now - last_ < every) return;
  last_ = now;
  std::string line;
  if (total > 0) {
    constexpr int kWidth = 30;
    const int filled = std::clamp(done * kWidth / total, 0, kWidth);
    line = fmt::format("{} [{}{}] {}/{} frames {:5.1f} fps, {} left", label_, std::string(filled, '#'),
                       std::string(kWidth - filled, '.'), done, total, rate, duration_text(eta_s));
  } else {
    line = fmt::format("{} {} frames {:5.1f} fps", label_, done, rate);
  }
  if (tty_)
    std::fprintf(stderr, "\r%s\033[K", line.c_str());
  else
    std::fprintf(stderr, "%s\n", line.c_str());
  std::fflush(stderr);
  drawn_ = true;
}

void ProgressBar::finish() {
  if (enabled_ && tty_ && drawn_) std::fputc('\n', stderr);
  drawn_ = false;
  enabled_ = false;
}

}  // namespace hdrd::cli
