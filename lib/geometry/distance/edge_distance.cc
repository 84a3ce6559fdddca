#include "geometry/distance/edge_distance.h"

#include <Eigen/Geometry>

#include "geometry/distance/distance_derivatives.h"

namespace aqs {

bool EdgeDistance(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& qa,
                  const Eigen::Vector3d& qb, double min_sine, double* s,
                  Eigen::Matrix<double, 3, 4>* gradient, double* u, double* v) {
  const Eigen::Vector3d e1 = pb - pa, e2 = qb - qa;
  const Eigen::Vector3d cross = e1.cross(e2);
  const double length = cross.norm();
  const double scale = e1.norm() * e2.norm();
  if (!(scale > 1e-300) || !(length > min_sine * scale)) return false;
  const Eigen::Vector3d n = cross / length;
  const Eigen::Vector3d d = pa - qa;
  *s = n.dot(d);
  if (gradient != nullptr) {
    // s = d . n(cr), cr = e1 x e2: ds = n . dd + w . dcr with w = (I - n n^T) d / |cr|,
    // and w . (de1 x e2 + e1 x de2) = de1 . (e2 x w) + de2 . (w x e1).
    const Eigen::Vector3d w = (d - n * *s) / length;
    const Eigen::Vector3d ds_de1 = e2.cross(w);
    const Eigen::Vector3d ds_de2 = w.cross(e1);
    gradient->col(0) = n - ds_de1;
    gradient->col(1) = ds_de1;
    gradient->col(2) = -n - ds_de2;
    gradient->col(3) = ds_de2;
  }
  // Closest points: minimize |d + u e1 - v e2|^2 (the normal equations' determinant is
  // -|e1 x e2|^2).
  const double aa = e1.dot(e1), ab = e1.dot(e2), bb = e2.dot(e2);
  const double ad = e1.dot(d), bd = e2.dot(d);
  const double det = length * length;
  if (u != nullptr) *u = (ab * bd - bb * ad) / det;
  if (v != nullptr) *v = (aa * bd - ab * ad) / det;
  return true;
}

bool EdgeDistanceHessian(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb,
                         const Eigen::Vector3d& qa, const Eigen::Vector3d& qb,
                         Eigen::Matrix<double, 12, 12>* hessian) {
  // (u, v, w) = (pb - pa, qb - qa, pa - qa): the coefficients of pa, pb, qa, qb in each.
  Eigen::Matrix<double, 3, 4> coefficients;
  coefficients << -1, 1, 0, 0,  //
                  0, 0, -1, 1,  //
                  1, 0, -1, 0;
  Eigen::Matrix<double, 9, 9> h;
  if (!UnitCrossDotHessian(pb - pa, qb - qa, pa - qa, &h)) return false;
  ScatterDifferenceHessian<3>(coefficients, h, hessian);
  return true;
}

}  // namespace aqs
