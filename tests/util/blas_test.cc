#include "util/blas.h"

#include <gtest/gtest.h>

namespace aqs {
namespace {

// Debian's Ceres links ATLAS; if it wins symbol resolution, CHOLMOD's dense kernels run
// single-threaded generic code (several times slower). The build must prevent that.
TEST(BlasTest, DgemmComesFromOpenBlas) {
  EXPECT_TRUE(DgemmIsOpenBlas()) << BlasDescription();
}

TEST(BlasTest, ThreadCountCanBeSet) {
  const int before = BlasThreads();
  SetBlasThreads(1);
  EXPECT_EQ(BlasThreads(), 1);
  SetBlasThreads(before);
  EXPECT_EQ(BlasThreads(), before);
}

}  // namespace
}  // namespace aqs
