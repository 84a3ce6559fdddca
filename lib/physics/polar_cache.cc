#include "physics/polar_cache.h"

#include <cstring>

namespace aqs {
namespace {

// Bit-for-bit equality of a matrix and a (possibly strided) Ref of the same shape.
template <typename Stored, typename Viewed>
bool SameBits(const Stored& stored, const Viewed& viewed) {
  if (stored.rows() != viewed.rows() || stored.cols() != viewed.cols()) return false;
  const size_t column_bytes = sizeof(double) * static_cast<size_t>(stored.rows());
  if (viewed.outerStride() == stored.rows()) {
    return std::memcmp(stored.data(), viewed.data(), column_bytes * stored.cols()) == 0;
  }
  for (Eigen::Index c = 0; c < stored.cols(); ++c) {
    if (std::memcmp(stored.col(c).data(), viewed.col(c).data(), column_bytes) != 0) return false;
  }
  return true;
}

}  // namespace

bool PolarCache::Matches(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                         const Eigen::Ref<const ActuationMatrix>& a) const {
  return valid_ && SameBits(x_, x) && SameBits(a_, a);
}

void PolarCache::Begin(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                       const Eigen::Ref<const ActuationMatrix>& a, int num_elements) {
  valid_ = false;
  x_ = x;
  a_ = a;
  svd_.resize(num_elements);
}

}  // namespace aqs
