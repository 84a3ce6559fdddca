#ifndef AQS_UTIL_PARALLEL_FOR_H_
#define AQS_UTIL_PARALLEL_FOR_H_

#include <functional>

namespace aqs {

// Runs body(thread_id, i) for every i in [begin, end) on up to num_threads threads
// (the calling thread is one of them). Work is handed out in chunks of `grain`
// consecutive indices from a shared counter, so uneven work balances. thread_id is in
// [0, number of threads used) and lets the body use per-thread scratch storage.
// num_threads <= 1, or a range shorter than two grains, runs serially in order.
// Where the system cannot start a thread, a warning is logged and the calling thread
// runs that thread's share (with its thread_id) after its own. The body must not throw.
void ParallelFor(int num_threads, int begin, int end,
                 const std::function<void(int thread_id, int i)>& body,
                 int grain = 256);

// As ParallelFor, but chunk c (indices begin + c grain .. begin + (c + 1) grain - 1)
// always goes to thread c mod T (T = ParallelForThreadCount(num_threads, count, grain)),
// in increasing c: which indices a thread sees, and in which order, is the same in every
// run with the same thread count, so per-thread partial sums reduced in thread order are
// bit-reproducible (with ParallelFor's shared counter they changed in their last bits
// from run to run). For loops whose iterations cost about the same (a mesh's elements);
// ParallelFor balances uneven ones (poses).
void ParallelForFixedOrder(int num_threads, int begin, int end,
                           const std::function<void(int thread_id, int i)>& body,
                           int grain = 256);

// The number of threads ParallelFor would use for a range of `count` indices.
int ParallelForThreadCount(int num_threads, int count, int grain = 256);

}  // namespace aqs

#endif  // AQS_UTIL_PARALLEL_FOR_H_
