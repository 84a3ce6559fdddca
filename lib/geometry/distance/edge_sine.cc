#include "geometry/distance/edge_sine.h"

#include <cmath>

#include <Eigen/Geometry>

#include "geometry/distance/distance_derivatives.h"

namespace aqs {

bool EdgeSine(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& qa,
              const Eigen::Vector3d& qb, double* sine, Eigen::Matrix<double, 3, 4>* gradient) {
  const Eigen::Vector3d e1 = pb - pa, e2 = qb - qa;
  const double a = e1.norm(), b = e2.norm();
  if (!(a > 1e-300) || !(b > 1e-300)) return false;
  const Eigen::Vector3d cross = e1.cross(e2);
  const double length = cross.norm();
  *sine = length / (a * b);
  if (gradient != nullptr) {
    // sine = |e1 x e2| / (|e1| |e2|): d|c| = de1 . (e2 x c) / |c| + de2 . (c x e1) / |c|.
    Eigen::Vector3d d_e1 = -*sine * e1 / (a * a), d_e2 = -*sine * e2 / (b * b);
    if (length > 1e-300) {
      d_e1 += e2.cross(cross) / (length * a * b);
      d_e2 += cross.cross(e1) / (length * a * b);
    }
    gradient->col(0) = -d_e1;
    gradient->col(1) = d_e1;
    gradient->col(2) = -d_e2;
    gradient->col(3) = d_e2;
  }
  return true;
}

bool EdgeSineHessian(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb,
                     const Eigen::Vector3d& qa, const Eigen::Vector3d& qb,
                     Eigen::Matrix<double, 12, 12>* hessian) {
  // sine = exp(phi), phi = log |m| - log |e1| - log |e2|, m = e1 x e2:
  // Hess sine = sine (Hess phi + grad phi grad phi^T). With g = m / |m|^2,
  // d2 log|m| / dm2 = (I - 2 n n^T) / |m|^2, and m bilinear (dm/de1 = -[e2]x,
  // dm/de2 = [e1]x, d2(g . m)/de1 de2 = -[g]x); d2 log|e| / de2 = (I - 2 e e^T / |e|^2) / |e|^2.
  const Eigen::Vector3d e1 = pb - pa, e2 = qb - qa;
  const Eigen::Vector3d m = e1.cross(e2);
  const double mm = m.squaredNorm(), aa = e1.squaredNorm(), bb = e2.squaredNorm();
  if (!(aa > 1e-300) || !(bb > 1e-300) || !(mm > 1e-300 * aa * bb)) return false;
  const double sine = std::sqrt(mm / (aa * bb));
  const Eigen::Matrix3d identity = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d g = m / mm;
  const Eigen::Matrix3d h_m = (identity - 2.0 * m * m.transpose() / mm) / mm;
  const Eigen::Matrix3d j1 = -CrossProductMatrix(e2), j2 = CrossProductMatrix(e1);
  Eigen::Matrix<double, 6, 1> grad_phi;
  grad_phi << j1.transpose() * g - e1 / aa, j2.transpose() * g - e2 / bb;
  Eigen::Matrix<double, 6, 6> h;
  h.block<3, 3>(0, 0) = j1.transpose() * h_m * j1 - (identity - 2.0 * e1 * e1.transpose() / aa) / aa;
  h.block<3, 3>(3, 3) = j2.transpose() * h_m * j2 - (identity - 2.0 * e2 * e2.transpose() / bb) / bb;
  h.block<3, 3>(0, 3) = j1.transpose() * h_m * j2 - CrossProductMatrix(g);
  h.block<3, 3>(3, 0) = h.block<3, 3>(0, 3).transpose();
  h = sine * (h + grad_phi * grad_phi.transpose());
  // (e1, e2) = (pb - pa, qb - qa): the coefficients of pa, pb, qa, qb in each.
  Eigen::Matrix<double, 2, 4> coefficients;
  coefficients << -1, 1, 0, 0,  //
                  0, 0, -1, 1;
  ScatterDifferenceHessian<2>(coefficients, h, hessian);
  return true;
}

}  // namespace aqs
