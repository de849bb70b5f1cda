#pragma once
// Internal: the library's one way to run work on several threads, under a thread budget.
//
// A thread's budget is how many threads the work it starts may use at once: the hardware's
// thread count (or MESHMARK_THREADS, when that environment variable holds a positive count) on
// a thread the library did not start. parallel_for and parallel_chunks never start more
// threads than the calling thread's budget, and split it among the threads they start (a
// worker of a loop of 2 threads on a budget of 8 has 4); so nested loops, a campaign's trials
// computing MSDM for instance, use the budget and not its square. A loop on a budget of 1 runs
// on the calling thread.
//
// parallel_chunks cuts [0, n) into contiguous chunks, chunk_count(n) of them; each index is
// computed the same way whatever the count, so results do not depend on it.

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace meshmark::detail {

/// The hardware's thread count, or MESHMARK_THREADS when positive; 1 to 64.
inline int default_thread_budget() {
  unsigned threads = std::thread::hardware_concurrency();
  if (const char* env = std::getenv("MESHMARK_THREADS"))
    if (const long wanted = std::strtol(env, nullptr, 10); wanted > 0)
      threads = static_cast<unsigned>(std::min(wanted, 64L));
  return static_cast<int>(std::max(1u, std::min(threads, 64u)));
}

/// The calling thread's budget (0: not set, default_thread_budget()).
inline int& thread_budget_slot() {
  thread_local int budget = 0;
  return budget;
}

/// How many threads work started from the calling thread may use at once (>= 1).
inline int thread_budget() {
  const int b = thread_budget_slot();
  return b > 0 ? b : default_thread_budget();
}

/// Sets the calling thread's budget for its lifetime (threads <= 0: the default), then
/// restores the earlier one.
class ThreadBudgetScope {
 public:
  explicit ThreadBudgetScope(int threads) : saved_(thread_budget_slot()) {
    thread_budget_slot() = std::max(0, threads);
  }
  ~ThreadBudgetScope() { thread_budget_slot() = saved_; }
  ThreadBudgetScope(const ThreadBudgetScope&) = delete;
  ThreadBudgetScope& operator=(const ThreadBudgetScope&) = delete;

 private:
  int saved_;
};

/// Runs body(i) for every i in [0, n) on up to `threads` threads (0: the calling thread's
/// budget; never more than it), each taking the next index when done with one (for items of
/// unequal cost). Every thread started runs with its share of the budget; with one thread the
/// bodies run on the calling thread, with its budget. The first exception
/// a body throws stops the others taking new items and is rethrown once they have finished.
template <class Body>
void parallel_for(std::int64_t n, int threads, Body&& body) {
  const int budget = thread_budget();
  const int count = static_cast<int>(
      std::min<std::int64_t>(std::max(1, threads > 0 ? std::min(threads, budget) : budget), n));
  if (count <= 1) {
    for (std::int64_t i = 0; i < n; ++i) body(i);
    return;
  }
  std::atomic<std::int64_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&](int share) {
    thread_budget_slot() = share;
    for (std::int64_t i; (i = next++) < n;) {
      try {
        body(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(error_mutex);
        if (!error) error = std::current_exception();
        next = n;
      }
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < count; ++t)
    pool.emplace_back(work, budget / count + (t < budget % count ? 1 : 0));
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);
}

/// Number of chunks parallel_chunks uses for n items on the calling thread (1 below 4096
/// items, else the thread's budget).
inline int chunk_count(std::int64_t n) {
  return n < 4096 ? 1 : thread_budget();
}

/// Calls body(chunk, begin, end) for chunk in [0, chunk_count(n)), the chunks covering [0, n)
/// in order, each on a thread of its own (with a budget of 1).
template <class Body>
void parallel_chunks(std::int64_t n, Body&& body) {
  const int chunks = chunk_count(n);
  if (chunks == 1) return body(0, std::int64_t{0}, n);
  parallel_for(chunks, chunks, [&](std::int64_t c) {
    body(static_cast<int>(c), n * c / chunks, n * (c + 1) / chunks);
  });
}

}  // namespace meshmark::detail
