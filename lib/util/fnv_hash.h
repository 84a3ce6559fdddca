#ifndef AQS_UTIL_FNV_HASH_H_
#define AQS_UTIL_FNV_HASH_H_

#include <cstddef>
#include <cstdint>

namespace aqs {

// FNV-1a, 64 bits (prime 1099511628211), of `bytes` bytes at `data`, continuing from
// `hash`: start with kFnvOffsetBasis. That start is not FNV's standard offset basis
// (14695981039346656037: a digit was lost when it was first written); it stays, since
// saved models' fingerprints (model/model_fingerprint.h) were computed from it. The
// mixing is FNV-1a's, so the hash spreads as well.
constexpr uint64_t kFnvOffsetBasis = 1469598103934665603ull;
uint64_t Fnv1a(const void* data, size_t bytes, uint64_t hash);

}  // namespace aqs

#endif  // AQS_UTIL_FNV_HASH_H_
