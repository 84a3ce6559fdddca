#ifndef AQS_UTIL_BLAS_H_
#define AQS_UTIL_BLAS_H_

#include <string>

namespace aqs {

// Threads OpenBLAS uses for the dense kernels of CHOLMOD's supernodal factorization
// (default: OPENBLAS_NUM_THREADS, else the number of cores).
void SetBlasThreads(int num_threads);
int BlasThreads();

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
