#include "util/allocation_policy.h"

#include <algorithm>
#include <climits>

#if defined(__GLIBC__)
#include <malloc.h>
#endif

namespace aqs {

bool ReuseLargeAllocations(double kept_bytes) {
#if defined(__GLIBC__)
  const int kept = static_cast<int>(std::clamp(kept_bytes, 0.0, static_cast<double>(INT_MAX)));
  return mallopt(M_MMAP_MAX, 0) == 1 && mallopt(M_TRIM_THRESHOLD, kept) == 1;
#else
  (void)kept_bytes;
  return false;
#endif
}

}  // namespace aqs
