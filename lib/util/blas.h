#ifndef AQS_UTIL_BLAS_H_
#define AQS_UTIL_BLAS_H_

#include <string>

namespace aqs {

// Threads OpenBLAS uses for the dense kernels of CHOLMOD's supernodal factorization
// (default: OPENBLAS_NUM_THREADS, else the number of cores).
void SetBlasThreads(int num_threads);
int BlasThreads();

// Sets the BLAS thread count for its lifetime and restores the previous one after.
class ScopedBlasThreads {
 public:
  explicit ScopedBlasThreads(int num_threads) : previous_(BlasThreads()) {
    SetBlasThreads(num_threads);
  }
  ~ScopedBlasThreads() { SetBlasThreads(previous_); }
  ScopedBlasThreads(const ScopedBlasThreads&) = delete;
  ScopedBlasThreads& operator=(const ScopedBlasThreads&) = delete;

 private:
  int previous_;
};

// Below this many non-zeros in the Cholesky factor, BLAS threads cost more than they
// give: the dense kernels are small, and OpenBLAS's idle threads spin (sched_yield)
// while the solver's own threads do the per-element work. Measured on the demo face
// (7.4e5 non-zeros): a 100-frame marker sequence at 1.95 frames/s with 2 BLAS threads,
// 2.30 with one; at 240K elements (2.7e7) a factorization takes 0.89 s with 2 and 1.36 s
// with one.
constexpr double kSmallFactorNonzeros = 2e6;

// The BLAS threads for solves whose factor has `factor_nonzeros` non-zeros: 1 below
// kSmallFactorNonzeros, else `threads`; the current count if OPENBLAS_NUM_THREADS is set
// (the user's choice).
int BlasThreadsForFactor(double factor_nonzeros, int threads);

// The shared library that provides dgemm_ in this process (resolved the way CHOLMOD's
// calls are), e.g. "/lib/x86_64-linux-gnu/libopenblas.so.0"; empty if unknown.
std::string DgemmProvider();

// True if dgemm_ comes from OpenBLAS (see cmake/FindAqsOpenBLAS.cmake for why this
// is worth checking on Debian).
bool DgemmIsOpenBlas();

// One line: OpenBLAS's build configuration, its thread count and the dgemm_ provider.
std::string BlasDescription();

}  // namespace aqs

#endif  // AQS_UTIL_BLAS_H_
