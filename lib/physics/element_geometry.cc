#include "physics/element_geometry.h"

#include <cmath>

#include <Eigen/LU>
#include <glog/logging.h>

namespace aqs {

ElementRestShape ComputeElementRestShape(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                                         const Eigen::Vector3d& x2, const Eigen::Vector3d& x3) {
  Eigen::Matrix3d dm;
  dm.col(0) = x1 - x0;
  dm.col(1) = x2 - x0;
  dm.col(2) = x3 - x0;
  const double det = dm.determinant();
  CHECK(det != 0.0 && std::isfinite(det)) << "degenerate rest element (det Dm = " << det << ")";
  ElementRestShape rest;
  rest.dm_inverse = dm.inverse();
  rest.volume = std::abs(det) / 6.0;
  return rest;
}

Eigen::Matrix<double, 3, 4> GradientWeights(const Eigen::Matrix3d& dm_inverse) {
  Eigen::Matrix<double, 3, 4> b;
  b.rightCols<3>() = dm_inverse.transpose();
  b.col(0) = -(b.col(1) + b.col(2) + b.col(3));
  return b;
}

Eigen::Matrix3d DeformationGradient(const Eigen::Matrix<double, 3, 4>& weights,
                                    const double* x0, const double* x1, const double* x2,
                                    const double* x3) {
  const double* x[4] = {x0, x1, x2, x3};
  Eigen::Matrix3d f = Eigen::Matrix3d::Zero();
  for (int k = 0; k < 4; ++k) {
    f.noalias() += Eigen::Map<const Eigen::Vector3d>(x[k]) * weights.col(k).transpose();
  }
  return f;
}

Eigen::Matrix<double, 9, 12> DeformationGradientJacobian(
    const Eigen::Matrix<double, 3, 4>& weights) {
  Eigen::Matrix<double, 9, 12> d = Eigen::Matrix<double, 9, 12>::Zero();
  for (int k = 0; k < 4; ++k) {
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) d(3 * a + b, 3 * k + a) = weights(b, k);
    }
  }
  return d;
}

Eigen::Matrix<double, 12, 12> ElementHessian(const Eigen::Matrix<double, 9, 9>& h,
                                             const Eigen::Matrix<double, 3, 4>& weights,
                                             double volume) {
  const Eigen::Matrix<double, 9, 12> d = DeformationGradientJacobian(weights);
  const Eigen::Matrix<double, 9, 12> hd = h * d;
  Eigen::Matrix<double, 12, 12> k = volume * (d.transpose() * hd);
  // Symmetrize exactly (h is symmetric; this removes round-off asymmetry).
  return 0.5 * (k + k.transpose());
}

}  // namespace aqs
