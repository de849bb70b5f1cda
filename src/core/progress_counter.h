#pragma once
// One phase of progress reports (progress.h), counted, one report at a time from any thread.

#include <mutex>
#include <string>

#include "meshmark/core/progress.h"

namespace meshmark::detail {

class ProgressCounter {
 public:
  /// Reports the phase's start (done 0) when there is work and a callback.
  ProgressCounter(const ProgressCallback& report, std::string phase, long total)
      : report_(report), phase_(std::move(phase)), total_(total) {
    if (report_ && total_ > 0) report_(phase_, 0, total_, "");
  }
  /// n more units done, the last of them `what`.
  void step(long n, const std::string& what) {
    std::lock_guard<std::mutex> lock(mutex_);
    done_ += n;
    if (report_) report_(phase_, done_, total_, what);
  }

 private:
  const ProgressCallback& report_;
  std::string phase_;
  long total_, done_ = 0;
  std::mutex mutex_;
};

}  // namespace meshmark::detail
