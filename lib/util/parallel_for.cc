#include "util/parallel_for.h"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <thread>
#include <vector>

namespace aqs {

int ParallelForThreadCount(int num_threads, int count, int grain) {
  if (count <= 0) return 1;
  const int chunks = (count + std::max(1, grain) - 1) / std::max(1, grain);
  if (chunks < 2) return 1;
  return std::max(1, std::min(num_threads, chunks));
}

namespace {

// Runs body(0, i) for i in [begin, end) in order if ParallelForThreadCount gives one
// thread; else worker(thread_id, threads, grain) on that many threads (the calling
// thread is thread 0), each covering its share of [begin, end).
void RunOnThreads(int num_threads, int begin, int end, int grain,
                  const std::function<void(int thread_id, int i)>& body,
                  const std::function<void(int thread_id, int threads, int grain)>& worker) {
  const int count = end - begin;
  if (count <= 0) return;
  grain = std::max(1, grain);
  const int threads = ParallelForThreadCount(num_threads, count, grain);
  if (threads <= 1) {
    for (int i = begin; i < end; ++i) body(0, i);
    return;
  }
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker, t, threads, grain);
  worker(0, threads, grain);
  for (std::thread& t : pool) t.join();
}

}  // namespace

void ParallelFor(int num_threads, int begin, int end,
                 const std::function<void(int thread_id, int i)>& body, int grain) {
  std::atomic<int> next(begin);
  RunOnThreads(num_threads, begin, end, grain, body, [&](int thread_id, int, int chunk) {
    while (true) {
      const int start = next.fetch_add(chunk);
      if (start >= end) break;
      const int stop = std::min(end, start + chunk);
      for (int i = start; i < stop; ++i) body(thread_id, i);
    }
  });
}

void ParallelForFixedOrder(int num_threads, int begin, int end,
                           const std::function<void(int thread_id, int i)>& body, int grain) {
  RunOnThreads(num_threads, begin, end, grain, body, [&](int thread_id, int threads, int chunk) {
    for (int64_t start = begin + static_cast<int64_t>(thread_id) * chunk; start < end;
         start += static_cast<int64_t>(threads) * chunk) {
      const int stop = static_cast<int>(std::min<int64_t>(end, start + chunk));
      for (int i = static_cast<int>(start); i < stop; ++i) body(thread_id, i);
    }
  });
}

}  // namespace aqs
