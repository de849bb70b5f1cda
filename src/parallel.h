#pragma once
// Internal: a parallel loop over an index range, in contiguous chunks, one per hardware
// thread (or per MESHMARK_THREADS, when that environment variable holds a positive count).
// Each index is computed the same way whatever the thread count, so results do not depend on
// it.

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <thread>
#include <vector>

namespace meshmark::detail {

/// Number of chunks parallel_chunks uses for n items.
inline int chunk_count(std::int64_t n) {
  if (n < 4096) return 1;
  unsigned threads = std::thread::hardware_concurrency();
  if (const char* env = std::getenv("MESHMARK_THREADS"))
    if (const long wanted = std::strtol(env, nullptr, 10); wanted > 0)
      threads = static_cast<unsigned>(std::min(wanted, 64L));
  return static_cast<int>(std::max(1u, std::min(threads, 64u)));
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
