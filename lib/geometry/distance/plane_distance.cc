#include "geometry/distance/plane_distance.h"

#include <Eigen/Geometry>
#include <Eigen/LU>

#include "geometry/distance/distance_derivatives.h"

namespace aqs {

bool PlaneDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                   const Eigen::Vector3d& c, double* s, Eigen::Matrix<double, 3, 4>* gradient,
                   Eigen::Vector3d* barycentric) {
  const Eigen::Vector3d e1 = b - a, e2 = c - a;
  const Eigen::Vector3d cross = e1.cross(e2);
  const double length = cross.norm();
  if (!(length > 1e-300)) return false;
  const Eigen::Vector3d n = cross / length;
  const Eigen::Vector3d v = p - a;
  *s = n.dot(v);
  if (gradient != nullptr) {
    // s = v . n(cr): ds = n . dv + u . dcr with u = (I - n n^T) v / |cr|.
    const Eigen::Vector3d u = (v - n * n.dot(v)) / length;
    const Eigen::Vector3d ds_db = e2.cross(u);
    const Eigen::Vector3d ds_dc = u.cross(e1);
    gradient->col(0) = n;
    gradient->col(1) = -n - ds_db - ds_dc;
    gradient->col(2) = ds_db;
    gradient->col(3) = ds_dc;
  }
  if (barycentric != nullptr) {
    const Eigen::Vector3d w = v - *s * n;
    Eigen::Matrix2d gram;
    gram << e1.dot(e1), e1.dot(e2), e1.dot(e2), e2.dot(e2);
    const Eigen::Vector2d beta = gram.inverse() * Eigen::Vector2d(e1.dot(w), e2.dot(w));
    *barycentric = Eigen::Vector3d(1.0 - beta[0] - beta[1], beta[0], beta[1]);
  }
  return true;
}

bool PlaneDistanceHessian(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                          const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                          Eigen::Matrix<double, 12, 12>* hessian) {
  // (u, v, w) = (b - a, c - a, p - a): the coefficients of p, a, b, c in each.
  Eigen::Matrix<double, 3, 4> coefficients;
  coefficients << 0, -1, 1, 0,  //
                  0, -1, 0, 1,  //
                  1, -1, 0, 0;
  Eigen::Matrix<double, 9, 9> h;
  if (!UnitCrossDotHessian(b - a, c - a, p - a, &h)) return false;
  ScatterDifferenceHessian<3>(coefficients, h, hessian);
  return true;
}

}  // namespace aqs
