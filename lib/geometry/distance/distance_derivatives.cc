#include "geometry/distance/distance_derivatives.h"

#include <Eigen/Geometry>

namespace aqs {

Eigen::Matrix3d CrossProductMatrix(const Eigen::Vector3d& a) {
  Eigen::Matrix3d m;
  m << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  return m;
}

bool UnitCrossDotHessian(const Eigen::Vector3d& u, const Eigen::Vector3d& v,
                         const Eigen::Vector3d& w, Eigen::Matrix<double, 9, 9>* hessian) {
  const Eigen::Vector3d m = u.cross(v);
  const double length = m.norm();
  if (!(length > 1e-300)) return false;
  const Eigen::Vector3d n = m / length;
  const double nw = n.dot(w);
  const Eigen::Matrix3d projector = Eigen::Matrix3d::Identity() - n * n.transpose();
  const Eigen::Vector3d w_perp = w - nw * n;
  const Eigen::Vector3d g = w_perp / length;
  const Eigen::Matrix3d h_mm =
      -(nw * projector + w_perp * n.transpose() + n * w_perp.transpose()) / (length * length);
  const Eigen::Matrix3d h_mw = projector / length;
  const Eigen::Matrix3d dm_du = -CrossProductMatrix(v), dm_dv = CrossProductMatrix(u);
  hessian->setZero();
  hessian->block<3, 3>(0, 0) = dm_du.transpose() * h_mm * dm_du;
  hessian->block<3, 3>(3, 3) = dm_dv.transpose() * h_mm * dm_dv;
  hessian->block<3, 3>(0, 3) = dm_du.transpose() * h_mm * dm_dv - CrossProductMatrix(g);
  hessian->block<3, 3>(3, 0) = hessian->block<3, 3>(0, 3).transpose();
  hessian->block<3, 3>(0, 6) = dm_du.transpose() * h_mw;
  hessian->block<3, 3>(6, 0) = hessian->block<3, 3>(0, 6).transpose();
  hessian->block<3, 3>(3, 6) = dm_dv.transpose() * h_mw;
  hessian->block<3, 3>(6, 3) = hessian->block<3, 3>(3, 6).transpose();
  return true;
}

}  // namespace aqs
