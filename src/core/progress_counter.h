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

/// One thread's share of a counted phase: units are added here and handed to the counter
/// every `every` of them (one lock per batch, not per unit), the rest by flush().
class ProgressBatch {
 public:
  /// Every 4,096 units by default: a few reports a second from a thread walking mesh vertices.
  explicit ProgressBatch(ProgressCounter& counter, long every = 4096)
      : counter_(counter), every_(every) {}
  ProgressBatch(const ProgressBatch&) = delete;
  ProgressBatch& operator=(const ProgressBatch&) = delete;
  void add(long n = 1) {
    if ((pending_ += n) >= every_) flush();
  }
  void flush() {
    if (pending_ > 0) counter_.step(pending_, "");
    pending_ = 0;
  }

 private:
  ProgressCounter& counter_;
  long every_, pending_ = 0;
};

}  // namespace meshmark::detail
