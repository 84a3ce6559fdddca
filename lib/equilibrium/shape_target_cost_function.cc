#include "equilibrium/shape_target_cost_function.h"

#include <cmath>

#include "physics/actuation.h"
#include "physics/element_geometry.h"
#include "physics/polar.h"

namespace aqs {

ShapeTargetCostFunction::ShapeTargetCostFunction(const Eigen::Matrix<double, 3, 4>& weights,
                                                 double volume, double mu,
                                                 const double* actuation)
    : weights_(weights), scale_(std::sqrt(2.0 * mu * volume)), actuation_(actuation) {}

bool ShapeTargetCostFunction::Evaluate(double const* const* parameters, double* residuals,
                                       double** jacobians) const {
  const Eigen::Matrix3d f = DeformationGradient(weights_, parameters[0], parameters[1],
                                                parameters[2], parameters[3]);
  const Eigen::Matrix3d s = SymmetricFromActuation(actuation_);
  const RotationVariantSvd svd = ComputeRotationVariantSvd(f * s);
  const Eigen::Matrix3d rs = PolarRotation(svd) * s;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) residuals[3 * a + b] = scale_ * (f(a, b) - rs(a, b));
  }
  if (jacobians == nullptr) return true;

  const PolarTwists twists = ComputePolarTwists(svd);
  Eigen::Matrix3d w[3];
  for (int t = 0; t < 3; ++t) w[t] = twists.twist[t] * s;
  for (int k = 0; k < 4; ++k) {
    if (jacobians[k] == nullptr) continue;
    Eigen::Map<Eigen::Matrix<double, 9, 3, Eigen::RowMajor>> jac(jacobians[k]);
    jac.setZero();
    const Eigen::Vector3d b = weights_.col(k);
    for (int a = 0; a < 3; ++a) {
      for (int c = 0; c < 3; ++c) jac(3 * a + c, a) = b[c];
    }
    for (int t = 0; t < 3; ++t) {
      const Eigen::Vector3d wb = twists.gain[t] * (w[t] * b);
      for (int a = 0; a < 3; ++a) {
        for (int c = 0; c < 3; ++c) jac.row(3 * a + c) -= w[t](a, c) * wb.transpose();
      }
    }
    jac *= scale_;
  }
  return true;
}

}  // namespace aqs
