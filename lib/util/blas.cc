#include "util/blas.h"

#include <dlfcn.h>

#include <cstdlib>
#include <sstream>

extern "C" {
// OpenBLAS's own API (declared here to avoid depending on its cblas.h location).
void openblas_set_num_threads(int num_threads);
int openblas_get_num_threads(void);
char* openblas_get_config(void);
}

namespace aqs {

void SetBlasThreads(int num_threads) { openblas_set_num_threads(num_threads); }

int BlasThreads() { return openblas_get_num_threads(); }

int BlasThreadsForFactor(double factor_nonzeros, int threads) {
  if (std::getenv("OPENBLAS_NUM_THREADS") != nullptr) return BlasThreads();
  return factor_nonzeros < kSmallFactorNonzeros ? 1 : threads;
}

std::string DgemmProvider() {
  void* symbol = dlsym(RTLD_DEFAULT, "dgemm_");
  if (symbol == nullptr) return "";
  Dl_info info;
  if (dladdr(symbol, &info) == 0 || info.dli_fname == nullptr) return "";
  return info.dli_fname;
}

bool DgemmIsOpenBlas() {
  // The provider must be the library that owns OpenBLAS's own entry points.
  Dl_info openblas;
  if (dladdr(reinterpret_cast<void*>(&openblas_get_config), &openblas) == 0) return false;
  const std::string provider = DgemmProvider();
  return !provider.empty() && openblas.dli_fname != nullptr &&
         provider == std::string(openblas.dli_fname);
}

std::string BlasDescription() {
  std::ostringstream out;
  out << openblas_get_config() << ", " << BlasThreads() << " threads; dgemm_ from "
      << (DgemmProvider().empty() ? "(unknown)" : DgemmProvider())
      << (DgemmIsOpenBlas() ? "" : " (NOT OpenBLAS: dense kernels are slow)");
  return out.str();
}

}  // namespace aqs
