// Splits [0, n) into contiguous chunks run on `threads` threads (inline when threads <= 1).
// Chunks are contiguous and in order, so callers can merge per-chunk results deterministically.
// f must not throw (a worker's exception would end the program): catch inside and rethrow after.
#pragma once

#include <algorithm>
#include <thread>
#include <vector>

namespace spikems {

template <class F>
void parallel_chunks(int n, int threads, F&& f) {
  threads = std::max(1, std::min(threads, n));
  if (threads == 1) {
    f(0, 0, n);
    return;
  }
  std::vector<std::thread> pool;
  for (int k = 1; k < threads; ++k)
    pool.emplace_back(
        [&, k] { f(k, int(int64_t(n) * k / threads), int(int64_t(n) * (k + 1) / threads)); });
  f(0, 0, int(int64_t(n) / threads));
  for (auto& th : pool) th.join();
}

}  // namespace spikems
