#include "util/parallel_for.h"

#include <atomic>
#include <climits>
#include <cstdint>
#include <cstring>
#include <vector>

#include <gtest/gtest.h>

#include "util/fault_injection.h"

namespace aqs {
namespace {

TEST(ParallelForTest, VisitsEveryIndexOnce) {
  for (int threads : {1, 2, 4}) {
    for (int grain : {1, 7, 256}) {
      std::vector<std::atomic<int>> visits(1000);
      for (auto& v : visits) v = 0;
      ParallelFor(threads, 0, 1000, [&](int, int i) { visits[i]++; }, grain);
      for (int i = 0; i < 1000; ++i) ASSERT_EQ(visits[i].load(), 1) << i;
    }
  }
}

TEST(ParallelForTest, ThreadIdsAreInRange) {
  const int threads = ParallelForThreadCount(3, 10000, 16);
  EXPECT_EQ(threads, 3);
  std::vector<std::atomic<int>> per_thread(threads);
  for (auto& v : per_thread) v = 0;
  ParallelFor(3, 0, 10000, [&](int t, int) {
    ASSERT_GE(t, 0);
    ASSERT_LT(t, threads);
    per_thread[t]++;
  }, 16);
  int total = 0;
  for (auto& v : per_thread) total += v;
  EXPECT_EQ(total, 10000);
}

TEST(ParallelForTest, EmptyAndShortRanges) {
  int calls = 0;
  ParallelFor(4, 5, 5, [&](int, int) { ++calls; });
  EXPECT_EQ(calls, 0);
  ParallelFor(4, 0, 3, [&](int t, int) { EXPECT_EQ(t, 0); ++calls; });
  EXPECT_EQ(calls, 3);
}

// Chunk c goes to thread c mod T, in increasing c: each thread's sequence of indices is
// the same in every run (per-thread partial sums are then reproducible).
TEST(ParallelForTest, FixedOrderGivesEachThreadTheSameIndicesInOrder) {
  for (int threads : {1, 2, 3}) {
    for (int grain : {1, 7, 64}) {
      const int begin = 5, end = 1000;
      const int used = ParallelForThreadCount(threads, end - begin, grain);
      std::vector<std::vector<int>> seen(used);
      ParallelForFixedOrder(threads, begin, end, [&](int t, int i) {
        ASSERT_LT(t, used);
        seen[t].push_back(i);
      }, grain);
      std::vector<std::vector<int>> expected(used);
      for (int i = begin; i < end; ++i) expected[((i - begin) / grain) % used].push_back(i);
      EXPECT_EQ(seen, expected) << threads << " threads, grain " << grain;
    }
  }
  int calls = 0;
  ParallelForFixedOrder(4, 5, 5, [&](int, int) { ++calls; });
  EXPECT_EQ(calls, 0);
}

// Where the system starts no thread after the first `kThreadsStarted` (its limit, or no
// address space for a stack), the calling thread runs the others' shares: every index
// once, each with the thread_id its share has, and in fixed order the same sequences.
constexpr int kThreadsStarted = 1;
int threads_asked = 0;
bool RefuseThreadsAfterTheFirst(const char* point) {
  return std::strcmp(point, "parallel_for:start_thread") == 0 &&
         ++threads_asked > kThreadsStarted;
}

TEST(ParallelForTest, ThreadsThatCannotStartRunOnTheCallingThread) {
  const FailureHook previous = SetFailureHookForTesting(&RefuseThreadsAfterTheFirst);
  const int begin = 3, end = 2000, grain = 16, used = ParallelForThreadCount(4, end - begin, 16);
  ASSERT_EQ(used, 4);
  threads_asked = 0;
  std::vector<std::atomic<int>> visits(end);
  for (auto& v : visits) v = 0;
  std::vector<std::atomic<int>> per_thread(used);
  for (auto& v : per_thread) v = 0;
  ParallelFor(4, begin, end, [&](int t, int i) {
    ASSERT_LT(t, used);
    per_thread[t]++;
    visits[i]++;
  }, grain);
  EXPECT_EQ(threads_asked, kThreadsStarted + 1);  // the first refusal ends the attempts
  for (int i = 0; i < end; ++i) ASSERT_EQ(visits[i].load(), i >= begin ? 1 : 0) << i;

  threads_asked = 0;
  std::vector<std::vector<int>> seen(used);
  ParallelForFixedOrder(4, begin, end, [&](int t, int i) {
    seen[t].push_back(i);  // threads 2 and 3 run on the calling thread, after thread 0
  }, grain);
  std::vector<std::vector<int>> expected(used);
  for (int i = begin; i < end; ++i) expected[((i - begin) / grain) % used].push_back(i);
  EXPECT_EQ(seen, expected);
  SetFailureHookForTesting(previous);
}

// The shared counter runs one chunk per thread past `end`: near INT_MAX it must not wrap
// to negative indices (it was an int).
TEST(ParallelForTest, RangesEndingNearIntMax) {
  const int end = INT_MAX - 5, begin = end - 1000;
  for (int grain : {1, 64, 256}) {
    std::atomic<int64_t> sum{0};
    std::atomic<int> calls{0}, outside{0};
    ParallelFor(4, begin, end, [&](int, int i) {
      if (i < begin || i >= end) outside++;
      calls++;
      sum += i - begin;
    }, grain);
    EXPECT_EQ(outside.load(), 0) << grain;
    EXPECT_EQ(calls.load(), 1000) << grain;
    EXPECT_EQ(sum.load(), 999 * 1000 / 2) << grain;
  }
}

}  // namespace
}  // namespace aqs
