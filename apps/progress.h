#pragma once
// Progress on stderr, from the library's reports (meshmark/core/progress.h): a bar with an ETA
// redrawn in place on a terminal, plain log lines, or nothing. Never on stdout, so --json
// output stays clean.

#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <string>

#include "meshmark/core/progress.h"

namespace meshmark::cli {

inline std::string format_duration(double s) {
  if (!(s >= 0) || s > 1e7) return "?";
  const long t = std::lround(s);
  return t >= 3600 ? fmt::format("{}h{:02}m", t / 3600, t / 60 % 60)
                   : fmt::format("{}m{:02}s", t / 60, t % 60);
}

// Progress on a terminal (a bar with an ETA, redrawn), or plain log lines; the library reports
// one phase after the other, each starting with done 0.
class Progress {
 public:
  enum Mode { Bar, Lines, Quiet };
  Progress(Mode mode, std::string prefix) : mode_(mode), prefix_(std::move(prefix)) {}
  void report(const std::string& phase, long done, long total, const std::string& note) {
    if (done == 0) {  // a phase starts
      finish();
      start_ = std::chrono::steady_clock::now();
      started_ = true;
      return;
    }
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    const double eta = elapsed / done * (total - done);
    if (mode_ == Bar) {
      const int width = 30;
      const int filled = total > 0 ? static_cast<int>(width * done / total) : width;
      fmt::print(stderr, "\r{}{} [{}{}] {}/{} ETA {}   ", prefix_, phase, std::string(filled, '#'),
                 std::string(width - filled, ' '), done, total, format_duration(eta));
    } else if (mode_ == Lines) {
      fmt::print(stderr, "{}{} {}/{} ({}) elapsed {} ETA {}\n", prefix_, phase, done, total, note,
                 format_duration(elapsed), format_duration(eta));
    }
  }
  // Ends the bar's line.
  void finish() {
    if (started_ && mode_ == Bar) fmt::print(stderr, "\n");
    started_ = false;
  }

 private:
  Mode mode_;
  std::string prefix_;
  bool started_ = false;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

/// A bar on stderr when it is a terminal and the output is not JSON; otherwise nothing. The
/// callback refers to progress, which must outlive it.
inline ProgressCallback terminal_progress(Progress& progress, bool json) {
  if (json || !isatty(STDERR_FILENO)) return {};
  return [&progress](const std::string& phase, long done, long total, const std::string& what) {
    progress.report(phase, done, total, what);
  };
}

}  // namespace meshmark::cli
