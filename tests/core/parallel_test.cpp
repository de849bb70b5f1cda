// parallel.h: loops never run more threads at once than the budget, nested loops included;
// a place left free goes to a loop still running; every index runs once; a body's exception
// reaches the caller.

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <thread>
#include <vector>

#include "core/parallel.h"

namespace meshmark {
namespace {

// Counts bodies running at once, and the most seen.
struct Concurrency {
  std::atomic<int> now{0}, most{0};
  void enter() {
    const int n = ++now;
    for (int m = most; n > m && !most.compare_exchange_weak(m, n);) {
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    --now;
  }
};

TEST(Parallel, NestedLoopsStayWithinTheBudgetAndRunEveryIndexOnce) {
  const detail::ThreadBudgetScope budget(3);
  Concurrency c;
  std::vector<std::atomic<int>> runs(8 * 20);
  detail::parallel_for(8, 0, [&](std::int64_t i) {
    detail::parallel_for(20, 0, [&](std::int64_t k) {
      c.enter();
      ++runs[i * 20 + k];
    });
    detail::parallel_chunks(10000, [&](int, std::int64_t, std::int64_t) { c.enter(); });
  });
  EXPECT_LE(c.most, 3);
  EXPECT_GE(c.most, 2);  // the outer loop did run in parallel
  for (const auto& r : runs) EXPECT_EQ(r, 1);
}

TEST(Parallel, TheLastItemRunningGetsTheThreadsTheOthersLeft) {
  const detail::ThreadBudgetScope budget(2);
  Concurrency c;
  detail::parallel_for(2, 0, [&](std::int64_t i) {
    if (i == 0) return;  // done at once: its thread's place is handed back
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    detail::parallel_for(40, 0, [&](std::int64_t) { c.enter(); });
  });
  EXPECT_EQ(c.most, 2);
}

TEST(Parallel, ABudgetOfOneRunsEverythingOnTheCallingThread) {
  const detail::ThreadBudgetScope budget(1);
  const std::thread::id caller = std::this_thread::get_id();
  std::atomic<int> elsewhere{0};
  detail::parallel_for(50, 0, [&](std::int64_t) {
    detail::parallel_chunks(100000, [&](int, std::int64_t, std::int64_t) {
      elsewhere += std::this_thread::get_id() != caller;
    });
    elsewhere += std::this_thread::get_id() != caller;
  });
  EXPECT_EQ(elsewhere, 0);
  EXPECT_EQ(detail::chunk_count(100000), 1);
}

TEST(Parallel, ABodysExceptionReachesTheCaller) {
  const detail::ThreadBudgetScope budget(4);
  EXPECT_THROW(detail::parallel_for(1000, 0,
                                    [&](std::int64_t i) {
                                      if (i == 3) throw std::runtime_error("item 3");
                                    }),
               std::runtime_error);
}

}  // namespace
}  // namespace meshmark
