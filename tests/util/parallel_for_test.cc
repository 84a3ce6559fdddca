#include "util/parallel_for.h"

#include <atomic>
#include <vector>

#include <gtest/gtest.h>

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

}  // namespace
}  // namespace aqs
