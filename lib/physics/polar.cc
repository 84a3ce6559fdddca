#include "physics/polar.h"

#include <algorithm>
#include <cmath>

namespace aqs {

Eigen::Matrix3d PolarRotation(const RotationVariantSvd& svd) {
  return svd.u * svd.v.transpose();
}

PolarTwists ComputePolarTwists(const RotationVariantSvd& svd) {
  static const int kPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  const double floor = kPolarDegenerateRatio * std::max(svd.sigma[0], 1.0);
  PolarTwists out;
  for (int k = 0; k < 3; ++k) {
    const int i = kPairs[k][0];
    const int j = kPairs[k][1];
    out.twist[k] = (svd.u.col(i) * svd.v.col(j).transpose() -
                    svd.u.col(j) * svd.v.col(i).transpose()) *
                   M_SQRT1_2;
    out.gain[k] = 2.0 / std::max(svd.sigma[i] + svd.sigma[j], floor);
  }
  return out;
}

Eigen::Matrix3d PolarRotationDerivative(const PolarTwists& twists, const Eigen::Matrix3d& dg) {
  Eigen::Matrix3d dr = Eigen::Matrix3d::Zero();
  for (int k = 0; k < 3; ++k) {
    dr += twists.gain[k] * twists.twist[k].cwiseProduct(dg).sum() * twists.twist[k];
  }
  return dr;
}

}  // namespace aqs
