#ifndef AQS_UTIL_PARALLEL_FOR_H_
#define AQS_UTIL_PARALLEL_FOR_H_

#include <functional>

namespace aqs {

// Runs body(thread_id, i) for every i in [begin, end) on up to num_threads threads
// (the calling thread is one of them). Work is handed out in chunks of `grain`
// consecutive indices from a shared counter, so uneven work balances. thread_id is in
// [0, number of threads used) and lets the body use per-thread scratch storage.
// num_threads <= 1, or a range shorter than two grains, runs serially in order.
// The body must not throw.
void ParallelFor(int num_threads, int begin, int end,
                 const std::function<void(int thread_id, int i)>& body,
                 int grain = 256);

// The number of threads ParallelFor would use for a range of `count` indices.
int ParallelForThreadCount(int num_threads, int count, int grain = 256);

}  // namespace aqs

#endif  // AQS_UTIL_PARALLEL_FOR_H_
