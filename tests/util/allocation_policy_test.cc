// util/allocation_policy.h: with ReuseLargeAllocations a large block comes from the heap
// (not a mapping of its own) and, freed, stays with the process for the next one. A test
// binary of its own: the policy is the whole process's.

#include "util/allocation_policy.h"

#include <cstdlib>
#include <cstring>

#include <gtest/gtest.h>

#include "testing/sanitizers.h"

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace aqs {
namespace {

#if defined(__GLIBC__)
TEST(AllocationPolicyTest, LargeBlocksComeFromTheHeapAndStay) {
  if (testing::kSanitizedAllocator) {
    GTEST_SKIP() << "a sanitizer's allocator replaces glibc's malloc, mallopt and mallinfo2";
  }
  constexpr size_t kBytes = size_t{64} << 20;  // above glibc's largest mmap threshold
  // By default such a block is a mapping of its own.
  void* block = std::malloc(kBytes);
  ASSERT_NE(block, nullptr);
  std::memset(block, 1, kBytes);
  EXPECT_GE(mallinfo2().hblkhd, kBytes);
  std::free(block);

  ASSERT_TRUE(ReuseLargeAllocations(kAppKeptAllocationBytes));
  block = std::malloc(kBytes);
  ASSERT_NE(block, nullptr);
  std::memset(block, 1, kBytes);
  EXPECT_LT(mallinfo2().hblkhd, kBytes) << "not mapped on its own";
  EXPECT_GE(mallinfo2().uordblks, kBytes) << "from the heap";
  std::free(block);
  EXPECT_GE(mallinfo2().arena, kBytes) << "kept after it was freed";
  EXPECT_GE(mallinfo2().fordblks, kBytes);
}
#endif

}  // namespace
}  // namespace aqs
