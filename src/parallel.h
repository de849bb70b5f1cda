#pragma once
// Internal: a parallel loop over an index range, in contiguous chunks, one per hardware
// thread (or per MESHMARK_THREADS, when that environment variable holds a positive count).
// Each index is computed the same way whatever the thread count, so results do not depend on
// it.

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <thread>
#include <vector>

namespace meshmark::detail {

/// True on a thread parallel_for started: loops run inside it stay on that thread, so that
/// nested parallel loops use the outer loop's threads instead of multiplying them.
inline thread_local bool in_parallel_worker = false;

/// The thread budget: MESHMARK_THREADS when that environment variable holds a positive count
/// (at most 64), else the hardware threads (at least 1, at most 64).
inline int thread_budget() {
  unsigned threads = std::thread::hardware_concurrency();
  if (const char* env = std::getenv("MESHMARK_THREADS"))
    if (const long wanted = std::strtol(env, nullptr, 10); wanted > 0)
      threads = static_cast<unsigned>(std::min(wanted, 64L));
  return static_cast<int>(std::max(1u, std::min(threads, 64u)));
}

/// Number of chunks parallel_chunks uses for n items (1 inside a parallel_for worker).
inline int chunk_count(std::int64_t n) {
  if (n < 4096 || in_parallel_worker) return 1;
  return thread_budget();
}

/// Calls body(i) for every i in [0, n), each index once, on min(threads, n) threads taking
/// the next index as they finish (threads <= 0: thread_budget()). Loops inside body run on
/// the calling worker's thread (in_parallel_worker). body must not throw (catch inside it).
/// Returns the threads used.
template <class Body>
int parallel_for(std::size_t n, int threads, Body&& body) {
  if (threads <= 0) threads = in_parallel_worker ? 1 : thread_budget();
  const int used = static_cast<int>(std::max<std::size_t>(1, std::min<std::size_t>(threads, n)));
  std::atomic<std::size_t> next{0};
  auto worker = [&] {
    const bool outer = in_parallel_worker;
    in_parallel_worker = used > 1 || outer;
    for (std::size_t i = next++; i < n; i = next++) body(i);
    in_parallel_worker = outer;
  };
  if (used == 1) {
    worker();
    return 1;
  }
  std::vector<std::thread> pool;
  for (int t = 0; t < used; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  return used;
}

/// Calls body(chunk, begin, end) for chunk in [0, chunk_count(n)), the chunks covering [0, n)
/// in order, on separate threads.
template <class Body>
void parallel_chunks(std::int64_t n, Body&& body) {
  const int chunks = chunk_count(n);
  if (chunks == 1) return body(0, std::int64_t{0}, n);
  std::vector<std::thread> pool;
  for (int c = 0; c < chunks; ++c)
    pool.emplace_back([&, c] { body(c, n * c / chunks, n * (c + 1) / chunks); });
  for (auto& t : pool) t.join();
}

}  // namespace meshmark::detail
