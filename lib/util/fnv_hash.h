#ifndef AQS_UTIL_FNV_HASH_H_
#define AQS_UTIL_FNV_HASH_H_

#include <cstddef>
#include <cstdint>
#include <string>

namespace aqs {

// FNV-1a, 64 bits (prime 1099511628211), of `bytes` bytes at `data`, continuing from
// `hash`: start with kFnvOffsetBasis. That start is not FNV's standard offset basis
// (14695981039346656037: a digit was lost when it was first written); it stays, since
// saved models' fingerprints (model/model_fingerprint.h) were computed from it. The
// mixing is FNV-1a's, so the hash spreads as well.
constexpr uint64_t kFnvOffsetBasis = 1469598103934665603ull;
uint64_t Fnv1a(const void* data, size_t bytes, uint64_t hash);

// Fnv1a over a sequence of arrays, matrices and strings, each preceded by its size (so
// that moving numbers from one array to the next changes the hash). Add(m) of an Eigen
// matrix hashes its row count, then its entries in storage order (count first).
class FnvHasher {
 public:
  template <typename Scalar>
  void Add(const Scalar* data, size_t count) {
    AddCount(count);
    hash_ = Fnv1a(data, sizeof(Scalar) * count, hash_);
  }
  template <typename Matrix>
  void AddMatrix(const Matrix& m) {
    AddCount(static_cast<size_t>(m.rows()));
    Add(m.data(), static_cast<size_t>(m.size()));
  }
  void Add(const std::string& text) { Add(text.data(), text.size()); }
  uint64_t hash() const { return hash_; }

 private:
  void AddCount(size_t count) {
    const uint64_t n = count;
    hash_ = Fnv1a(&n, sizeof(n), hash_);
  }
  uint64_t hash_ = kFnvOffsetBasis;
};

}  // namespace aqs

#endif  // AQS_UTIL_FNV_HASH_H_
