// Progress of long work on stderr (stdout carries results): on a terminal, one line
// redrawn in place — a bar, frames done of total, the rate and the time left; otherwise
// (a log, CI) a plain line at most every few seconds and at the end. hdrd and hdrctl
// show sequences with it.
#pragma once

#include <chrono>
#include <string>

namespace hdrd::cli {

class ProgressBar {
 public:
  ProgressBar(std::string label, bool enabled);
  ~ProgressBar();  // ends the line if one was drawn
  // done of total units (total 0: unknown), rate in units per second, eta in seconds.
  void update(int done, int total, double rate, double eta_s);
  void finish();

 private:
  std::string label_;
  bool enabled_, tty_, drawn_ = false;
  std::chrono::steady_clock::time_point last_{};
};

// "1:05", "12:00:07" (whole seconds).
std::string duration_text(double seconds);

}  // namespace hdrd::cli
