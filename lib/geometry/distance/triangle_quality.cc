#include "geometry/distance/triangle_quality.h"

#include <cmath>

#include <Eigen/Geometry>

#include "geometry/distance/distance_derivatives.h"

namespace aqs {

bool TriangleQuality(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                     double* quality, Eigen::Matrix3d* gradient) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a;
  const double sum = 2.0 * e1.squaredNorm() + 2.0 * e2.squaredNorm() - 2.0 * e1.dot(e2);
  if (!(sum > 1e-300)) return false;
  const Eigen::Vector3d m = e1.cross(e2);
  const double length = m.norm();
  *quality = 2.0 * length / sum;
  if (gradient != nullptr) {
    // q = 2 |m| / S: dq = 2 d|m| / S - q dS / S, d|m| = de1 . (e2 x n) + de2 . (n x e1)
    // (zero where m vanishes: the one-sided derivative of |m| along the degenerate
    // direction), dS = de1 . (4 e1 - 2 e2) + de2 . (4 e2 - 2 e1).
    Eigen::Vector3d d_e1 = -*quality * (4.0 * e1 - 2.0 * e2) / sum;
    Eigen::Vector3d d_e2 = -*quality * (4.0 * e2 - 2.0 * e1) / sum;
    if (length > 1e-300) {
      const Eigen::Vector3d n = m / length;
      d_e1 += 2.0 * e2.cross(n) / sum;
      d_e2 += 2.0 * n.cross(e1) / sum;
    }
    gradient->col(0) = -d_e1 - d_e2;
    gradient->col(1) = d_e1;
    gradient->col(2) = d_e2;
  }
  return true;
}

bool TriangleQualityHessian(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            const Eigen::Vector3d& c, Eigen::Matrix<double, 9, 9>* hessian) {
  // q = 2 exp(phi), phi = log |m| - log S: Hess q = q (Hess phi + grad phi grad phi^T) with
  // respect to (e1, e2). With g = m / |m|^2, d2 log|m| / dm2 = (I - 2 n n^T) / |m|^2 and m
  // bilinear (dm/de1 = -[e2]x, dm/de2 = [e1]x, d2(g . m)/de1 de2 = -[g]x); S is quadratic
  // (Hess S = [4I -2I; -2I 4I]) and Hess log S = Hess S / S - grad S grad S^T / S^2.
  const Eigen::Vector3d e1 = b - a, e2 = c - a;
  const Eigen::Vector3d m = e1.cross(e2);
  const double mm = m.squaredNorm();
  const double sum = 2.0 * e1.squaredNorm() + 2.0 * e2.squaredNorm() - 2.0 * e1.dot(e2);
  if (!(sum > 1e-300) || !(mm > 1e-300 * sum * sum)) return false;
  const double quality = 2.0 * std::sqrt(mm) / sum;
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d g = m / mm;
  const Eigen::Matrix3d h_m = (identity - 2.0 * m * m.transpose() / mm) / mm;
  const Eigen::Matrix3d j1 = -CrossProductMatrix(e2), j2 = CrossProductMatrix(e1);
  Eigen::Matrix<double, 6, 1> grad_sum;
  grad_sum << 4.0 * e1 - 2.0 * e2, 4.0 * e2 - 2.0 * e1;
  Eigen::Matrix<double, 6, 1> grad_phi;
  grad_phi << j1.transpose() * g, j2.transpose() * g;
  grad_phi -= grad_sum / sum;
  Eigen::Matrix<double, 6, 6> hess_sum;
  hess_sum << 4.0 * identity, -2.0 * identity, -2.0 * identity, 4.0 * identity;
  Eigen::Matrix<double, 6, 6> h;
  h.block<3, 3>(0, 0) = j1.transpose() * h_m * j1;
  h.block<3, 3>(3, 3) = j2.transpose() * h_m * j2;
  h.block<3, 3>(0, 3) = j1.transpose() * h_m * j2 - CrossProductMatrix(g);
  h.block<3, 3>(3, 0) = h.block<3, 3>(0, 3).transpose();
  h -= hess_sum / sum - grad_sum * grad_sum.transpose() / (sum * sum);
  h = quality * (h + grad_phi * grad_phi.transpose());
  // (e1, e2) = (b - a, c - a): the coefficients of a, b, c in each.
  Eigen::Matrix<double, 2, 3> coefficients;
  coefficients << -1, 1, 0,  //
                  -1, 0, 1;
  ScatterDifferenceHessian<2, 3>(coefficients, h, hessian);
  return true;
}

}  // namespace aqs
