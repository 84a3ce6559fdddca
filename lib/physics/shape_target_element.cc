#include "physics/shape_target_element.h"

#include <Eigen/Eigenvalues>
#include <Eigen/QR>

namespace aqs {

Vector9d VecRowMajor(const Eigen::Matrix3d& m) {
  Vector9d v;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) v[3 * a + b] = m(a, b);
  }
  return v;
}

Eigen::Matrix3d UnvecRowMajor(const Vector9d& v) {
  Eigen::Matrix3d m;
  for (int a = 0; a < 3; ++a) {
    for (int b = 0; b < 3; ++b) m(a, b) = v[3 * a + b];
  }
  return m;
}

ShapeTargetElement::ShapeTargetElement(const Eigen::Matrix3d& f, const Eigen::Matrix3d& s,
                                       double mu)
    : ShapeTargetElement(f, s, mu, ComputeRotationVariantSvd(f * s)) {}

ShapeTargetElement::ShapeTargetElement(const Eigen::Matrix3d& f, const Eigen::Matrix3d& s,
                                       double mu, const RotationVariantSvd& svd)
    : f_(f), s_(s), mu_(mu), svd_(svd) {
  r_ = PolarRotation(svd_);
  twists_ = ComputePolarTwists(svd_);
}

double ShapeTargetElement::EnergyDensity() const { return mu_ * Deviation().squaredNorm(); }

Eigen::Matrix3d ShapeTargetElement::Stress() const { return 2.0 * mu_ * Deviation(); }

Matrix9d ShapeTargetElement::DeviationJacobian() const {
  Matrix9d j = Matrix9d::Identity();
  for (int k = 0; k < 3; ++k) {
    const Vector9d w = VecRowMajor(twists_.twist[k] * s_);
    j.noalias() -= twists_.gain[k] * w * w.transpose();
  }
  return j;
}

Matrix9d ShapeTargetElement::StressDerivative() const {
  return 2.0 * mu_ * DeviationJacobian();
}

Matrix9d ShapeTargetElement::ProjectedStressDerivative() const {
  // dP/dF = 2 mu (I - W C W^T), W = [w_0 w_1 w_2] (9x3), C = diag(gain).
  // With W = Q [T; 0] (Householder QR, Q orthogonal 9x9, T 3x3 upper triangular):
  // Q^T (I - W C W^T) Q = blockdiag(I3 - T C T^T, I6).
  Eigen::Matrix<double, 9, 3> w;
  for (int k = 0; k < 3; ++k) w.col(k) = VecRowMajor(twists_.twist[k] * s_);
  Eigen::HouseholderQR<Eigen::Matrix<double, 9, 3>> qr(w);
  const Eigen::Matrix3d t = qr.matrixQR().topRows<3>().triangularView<Eigen::Upper>();
  const Eigen::Matrix3d block =
      Eigen::Matrix3d::Identity() - t * twists_.gain.asDiagonal() * t.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(block);
  const Eigen::Vector3d clamped = eig.eigenvalues().cwiseMax(0.0);
  const Eigen::Matrix3d block_psd =
      eig.eigenvectors() * clamped.asDiagonal() * eig.eigenvectors().transpose();
  const Matrix9d q = qr.householderQ();
  const Eigen::Matrix<double, 9, 3> q1 = q.leftCols<3>();
  Matrix9d h = Matrix9d::Identity();
  h.noalias() += q1 * (block_psd - Eigen::Matrix3d::Identity()) * q1.transpose();
  return 2.0 * mu_ * h;
}

Vector6d ShapeTargetElement::EnergyActuationGradient() const {
  const Eigen::Matrix3d rtf = r_.transpose() * f_;
  const Eigen::Matrix3d g = 2.0 * mu_ * (s_ - 0.5 * (rtf + rtf.transpose()));
  return ActuationGradientFromMatrixGradient(g);
}

Eigen::Matrix3d ShapeTargetElement::StressActuationDirectional(const Eigen::Matrix3d& ds) const {
  const Eigen::Matrix3d dr = PolarRotationDerivative(twists_, f_ * ds);
  return -2.0 * mu_ * (dr * s_ + r_ * ds);
}

Matrix96d ShapeTargetElement::StressActuationDerivative() const {
  Matrix96d d;
  for (int k = 0; k < 6; ++k) {
    d.col(k) = VecRowMajor(StressActuationDirectional(ActuationBasisMatrix(k)));
  }
  return d;
}

Vector6d ShapeTargetElement::StressActuationAdjoint(const Eigen::Matrix3d& x) const {
  // <X, dP/dS[dS]> = -2 mu (<X S, dR[F dS]> + <R^T X, dS>)
  //               = -2 mu <R^T X + sum_k gain_k <twist_k, X S> F^T twist_k, dS>.
  const Eigen::Matrix3d xs = x * s_;
  Eigen::Matrix3d y = r_.transpose() * x;
  for (int k = 0; k < 3; ++k) {
    y.noalias() += twists_.gain[k] * twists_.twist[k].cwiseProduct(xs).sum() *
                   (f_.transpose() * twists_.twist[k]);
  }
  return ActuationGradientFromMatrixGradient(-2.0 * mu_ * y);
}

}  // namespace aqs
