#include "physics/polar.h"

#include <algorithm>
#include <cmath>

#include <Eigen/LU>
#include <Eigen/SVD>

// GCC 12 reports a false -Wmaybe-uninitialized inside Eigen's 3x3 JacobiSVD.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

namespace aqs {

RotationVariantSvd ComputeRotationVariantSvd(const Eigen::Matrix3d& g) {
  Eigen::JacobiSVD<Eigen::Matrix3d, Eigen::NoQRPreconditioner> svd(
      g, Eigen::ComputeFullU | Eigen::ComputeFullV);
  RotationVariantSvd out;
  out.u = svd.matrixU();
  out.v = svd.matrixV();
  out.sigma = svd.singularValues();
  // Move reflections into the smallest singular value so both factors are rotations.
  if (out.u.determinant() < 0) {
    out.u.col(2) *= -1.0;
    out.sigma[2] *= -1.0;
  }
  if (out.v.determinant() < 0) {
    out.v.col(2) *= -1.0;
    out.sigma[2] *= -1.0;
  }
  return out;
}

Eigen::Matrix3d PolarRotation(const RotationVariantSvd& svd) {
  return svd.u * svd.v.transpose();
}

PolarTwists ComputePolarTwists(const RotationVariantSvd& svd) {
  static const int kPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  const double floor =
      kPolarDegenerateRatio * std::max(svd.sigma[0], 1e-100);
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
