#pragma once
// Internal: the library's one way to run work on several threads, under a thread budget.
//
// A budget is a number of threads that may run at once, shared by a loop and every loop nested
// in it: on a thread the library did not start, the hardware's thread count (or
// MESHMARK_THREADS, when that environment variable holds a positive count); inside a
// ThreadBudgetScope, the scope's. A loop starts only the helper threads the budget has free and
// its thread works beside them; a helper that finds no item left hands its place back, for a
// loop nested in a body still running to take. So a campaign's trials computing MSDM use the
// budget and not its square, and the last trial running alone gets the threads the others
// left. A budget of 1 runs everything on the calling thread.
//
// parallel_chunks cuts [0, n) into contiguous chunks, chunk_count(n) of them (the budget's
// size, whatever is free); each index is computed the same way whatever the count, so results
// depend neither on the budget nor on how busy it is.

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <mutex>
#include <optional>
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

/// Threads that may run at once: the size, and the places free (the thread that made it holds
/// one). Free places may be negative for a moment (a loop's thread taking its place back).
class ThreadBudget {
 public:
  explicit ThreadBudget(int size) : size_(std::max(1, size)), free_(size_ - 1) {}
  int size() const { return size_; }
  /// Takes up to `wanted` free places; returns how many.
  int take(int wanted) {
    for (int f = free_.load(); wanted > 0 && f > 0;)
      if (free_.compare_exchange_weak(f, f - std::min(f, wanted))) return std::min(f, wanted);
    return 0;
  }
  /// Hands n places back.
  void give(int n) { free_ += n; }
  /// Takes a place back whether free or not (a thread that waited resumes).
  void reclaim() { --free_; }

 private:
  int size_;
  std::atomic<int> free_;
};

/// The calling thread's budget, when a loop or a ThreadBudgetScope set one.
inline ThreadBudget*& thread_budget_slot() {
  thread_local ThreadBudget* budget = nullptr;
  return budget;
}

/// The calling thread's budget (a default one of default_thread_budget() per thread).
inline ThreadBudget& current_thread_budget() {
  if (ThreadBudget* b = thread_budget_slot()) return *b;
  thread_local ThreadBudget fallback(default_thread_budget());
  return fallback;
}

/// The size of the calling thread's budget (>= 1).
inline int thread_budget() {
  return current_thread_budget().size();
}

/// Gives the calling thread a budget of its own, of `threads` (<= 0: the default), for the
/// scope's lifetime, then restores the earlier one.
class ThreadBudgetScope {
 public:
  explicit ThreadBudgetScope(int threads)
      : budget_(threads > 0 ? threads : default_thread_budget()), saved_(thread_budget_slot()) {
    thread_budget_slot() = &budget_;
  }
  ~ThreadBudgetScope() { thread_budget_slot() = saved_; }
  ThreadBudgetScope(const ThreadBudgetScope&) = delete;
  ThreadBudgetScope& operator=(const ThreadBudgetScope&) = delete;

 private:
  ThreadBudget budget_;
  ThreadBudget* saved_;
};

/// Runs body(i) for every i in [0, n), each index once, on the calling thread and helpers,
/// each taking the next index when done with one (for items of unequal cost). threads <= 0:
/// as many as the calling thread's budget has free; threads > 0: at most that many, and on a
/// thread without a budget (not in a loop or a ThreadBudgetScope) the loop's budget is
/// threads. Loops in the bodies share the same budget. The first exception a body throws stops
/// the others taking new items and is rethrown once they have finished. Returns the threads
/// used (1: the calling thread alone).
template <class Body>
int parallel_for(std::int64_t n, int threads, Body&& body) {
  std::optional<ThreadBudget> own;  // an explicit count on a thread without a budget
  if (threads > 0 && !thread_budget_slot()) own.emplace(threads);
  ThreadBudget& budget = own ? *own : current_thread_budget();
  struct Slot {  // the calling thread works under the loop's budget, then gets its own back
    ThreadBudget* saved = thread_budget_slot();
    ~Slot() { thread_budget_slot() = saved; }
  } slot;
  thread_budget_slot() = &budget;
  const int wanted =
      static_cast<int>(std::min<std::int64_t>(n, threads > 0 ? threads : budget.size()));
  const int helpers = wanted > 1 ? budget.take(wanted - 1) : 0;
  if (helpers == 0) {
    for (std::int64_t i = 0; i < n; ++i) body(i);
    return 1;
  }
  std::atomic<std::int64_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  auto work = [&] {
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
  pool.reserve(static_cast<std::size_t>(std::max(helpers, 0)));
  for (int t = 0; t < helpers; ++t)
    pool.emplace_back([&] {
      thread_budget_slot() = &budget;
      work();
      budget.give(1);
    });
  work();
  budget.give(1);  // while this thread waits, its place is free
  for (auto& t : pool) t.join();
  budget.reclaim();
  if (error) std::rethrow_exception(error);
  return helpers + 1;
}

/// Number of chunks parallel_chunks uses for n items on the calling thread (1 below 4096
/// items, else the size of the thread's budget).
inline int chunk_count(std::int64_t n) {
  return n < 4096 ? 1 : thread_budget();
}

/// Calls body(chunk, begin, end) for chunk in [0, chunk_count(n)), the chunks covering [0, n)
/// in order, on the threads the budget has free (parallel_for).
template <class Body>
void parallel_chunks(std::int64_t n, Body&& body) {
  const int chunks = chunk_count(n);
  if (chunks == 1) return body(0, std::int64_t{0}, n);
  (void)parallel_for(chunks, chunks, [&](std::int64_t c) {
    body(static_cast<int>(c), n * c / chunks, n * (c + 1) / chunks);
  });
}

}  // namespace meshmark::detail
