# Finds OpenBLAS (Debian: libopenblas-pthread-dev) and defines aqs::openblas.
#
# Why a direct link: Debian 12's libceres.so.3 links ATLAS's libf77blas.so.3, which the
# dynamic loader would otherwise load before OpenBLAS's libblas.so.3, so that every
# dgemm_ in the process (CHOLMOD's supernodal factorization included) ran ATLAS's
# single-threaded generic kernels. Linking OpenBLAS ahead of Ceres makes its symbols
# win (measured in docs/benchmarks.md).
find_library(AQS_OPENBLAS_LIBRARY NAMES openblas)
include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(AqsOpenBLAS DEFAULT_MSG AQS_OPENBLAS_LIBRARY)
if(AqsOpenBLAS_FOUND AND NOT TARGET aqs::openblas)
  add_library(aqs::openblas UNKNOWN IMPORTED)
  set_target_properties(aqs::openblas PROPERTIES IMPORTED_LOCATION "${AQS_OPENBLAS_LIBRARY}")
endif()
mark_as_advanced(AQS_OPENBLAS_LIBRARY)
