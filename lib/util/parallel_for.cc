#include "util/parallel_for.h"

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace aqs {

int ParallelForThreadCount(int num_threads, int count, int grain) {
  if (count <= 0) return 1;
  const int chunks = (count + std::max(1, grain) - 1) / std::max(1, grain);
  if (chunks < 2) return 1;
  return std::max(1, std::min(num_threads, chunks));
}

void ParallelFor(int num_threads, int begin, int end,
                 const std::function<void(int thread_id, int i)>& body, int grain) {
  const int count = end - begin;
  if (count <= 0) return;
  grain = std::max(1, grain);
  const int threads = ParallelForThreadCount(num_threads, count, grain);
  if (threads <= 1) {
    for (int i = begin; i < end; ++i) body(0, i);
    return;
  }
  std::atomic<int> next(begin);
  auto worker = [&](int thread_id) {
    while (true) {
      const int start = next.fetch_add(grain);
      if (start >= end) break;
      const int stop = std::min(end, start + grain);
      for (int i = start; i < stop; ++i) body(thread_id, i);
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker, t);
  worker(0);
  for (std::thread& t : pool) t.join();
}

void ParallelForFixedOrder(int num_threads, int begin, int end,
                           const std::function<void(int thread_id, int i)>& body, int grain) {
  const int count = end - begin;
  if (count <= 0) return;
  grain = std::max(1, grain);
  const int threads = ParallelForThreadCount(num_threads, count, grain);
  if (threads <= 1) {
    for (int i = begin; i < end; ++i) body(0, i);
    return;
  }
  const int chunks = (count + grain - 1) / grain;
  auto worker = [&](int thread_id) {
    for (int c = thread_id; c < chunks; c += threads) {
      const int start = begin + c * grain;
      const int stop = std::min(end, start + grain);
      for (int i = start; i < stop; ++i) body(thread_id, i);
    }
  };
  std::vector<std::thread> pool;
  pool.reserve(threads - 1);
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker, t);
  worker(0);
  for (std::thread& t : pool) t.join();
}

}  // namespace aqs
