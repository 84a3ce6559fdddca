#include "util/parallel_for.h"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <system_error>
#include <thread>
#include <vector>

#include <glog/logging.h>

#include "util/fault_injection.h"

namespace aqs {

int ParallelForThreadCount(int num_threads, int count, int grain) {
  if (count <= 0) return 1;
  const int64_t step = std::max(1, grain);
  const int64_t chunks = (count + step - 1) / step;
  if (chunks < 2) return 1;
  return static_cast<int>(std::max<int64_t>(1, std::min<int64_t>(num_threads, chunks)));
}

namespace {

// Runs body(0, i) for i in [begin, end) in order if ParallelForThreadCount gives one
// thread; else worker(thread_id, threads, grain) for thread_id in [0, threads), each
// covering its share of [begin, end): thread 0 on the calling thread, the others on
// threads of their own. A thread the system cannot start (its thread limit, or no address
// space for the stack) is warned about and its worker runs on the calling thread after
// thread 0's, so every share still runs once with its own thread_id.
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
  int started = 1;
  for (; started < threads; ++started) {
    try {
      if (FailurePoint("parallel_for:start_thread")) {  // a test's stand-in for the system
        throw std::system_error(std::make_error_code(std::errc::resource_unavailable_try_again));
      }
      pool.emplace_back(worker, started, threads, grain);
    } catch (const std::system_error& e) {
      LOG(WARNING) << "could not start thread " << started << " of " << threads << " ("
                   << e.what() << "); the calling thread runs the rest of the work";
      break;
    }
  }
  worker(0, threads, grain);
  for (int t = started; t < threads; ++t) worker(t, threads, grain);
  for (std::thread& t : pool) t.join();
}

}  // namespace

void ParallelFor(int num_threads, int begin, int end,
                 const std::function<void(int thread_id, int i)>& body, int grain) {
  // 64 bits: each worker takes one chunk past `end`, which must not wrap near INT_MAX.
  std::atomic<int64_t> next(begin);
  RunOnThreads(num_threads, begin, end, grain, body, [&](int thread_id, int, int chunk) {
    while (true) {
      const int64_t start = next.fetch_add(chunk);
      if (start >= end) break;
      const int stop = static_cast<int>(std::min<int64_t>(end, start + chunk));
      for (int i = static_cast<int>(start); i < stop; ++i) body(thread_id, i);
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
