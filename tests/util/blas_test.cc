#include "util/blas.h"

#include <cstdlib>
#include <string>

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

TEST(BlasTest, ScopedThreadsRestoreTheCount) {
  const int before = BlasThreads();
  {
    const ScopedBlasThreads one(1);
    EXPECT_EQ(BlasThreads(), 1);
  }
  EXPECT_EQ(BlasThreads(), before);
}

// Small factors get one BLAS thread, large ones the count asked for, unless the user
// set OPENBLAS_NUM_THREADS (then the current count stays).
TEST(BlasTest, ThreadsForFactorFollowItsSize) {
  const char* env = std::getenv("OPENBLAS_NUM_THREADS");
  const std::string saved = env != nullptr ? env : "";
  unsetenv("OPENBLAS_NUM_THREADS");
  EXPECT_EQ(BlasThreadsForFactor(7.4e5, 2), 1);
  EXPECT_EQ(BlasThreadsForFactor(2.7e7, 2), 2);
  EXPECT_EQ(BlasThreadsForFactor(kSmallFactorNonzeros, 3), 3);
  setenv("OPENBLAS_NUM_THREADS", "2", 1);
  EXPECT_EQ(BlasThreadsForFactor(7.4e5, 2), BlasThreads());
  if (env != nullptr) {
    setenv("OPENBLAS_NUM_THREADS", saved.c_str(), 1);
  } else {
    unsetenv("OPENBLAS_NUM_THREADS");
  }
}

}  // namespace
}  // namespace aqs
