#ifndef AQS_UTIL_ALLOCATION_POLICY_H_
#define AQS_UTIL_ALLOCATION_POLICY_H_

namespace aqs {

// The C library allocator's policy for large blocks, for a whole process (the apps set
// it at start, apps/app_common.cc InitApp; a library leaves it to its host).
//
// glibc gives every block above its mmap threshold (which it raises as blocks are freed,
// but never above 32 MB) a mapping of its own and unmaps it when the block is freed: the
// next such block is mapped again, and the kernel zeroes each of its pages on first
// touch. Ceres' L-BFGS allocates vectors of the problem's size at every line-search step:
// on the full face (5 million decoder parameters, 40 MB per vector) pre-training spent
// 28 of its 99 s in the kernel doing so, and the auto-encoder baseline 48 of 143 s
// (docs/benchmarks.md).
//
// ReuseLargeAllocations takes every block from the heap (glibc's M_MMAP_MAX = 0) and
// keeps up to `kept_bytes` of freed memory at the heap's top for reuse instead of
// returning it to the system (M_TRIM_THRESHOLD). Returns false if the allocator refused
// (or is not glibc's: then nothing changes).
bool ReuseLargeAllocations(double kept_bytes);

// What the apps keep: 1 GB.
inline constexpr double kAppKeptAllocationBytes = 1e9;

}  // namespace aqs

#endif  // AQS_UTIL_ALLOCATION_POLICY_H_
