#include "fit/bone_parameters.h"

#include <ceres/jet.h>
#include <ceres/rotation.h>
#include <Eigen/Geometry>

namespace aqs {

RigidTransform BoneTransformFromParameters(const double* parameters) {
  const Eigen::Vector3d omega(parameters[0], parameters[1], parameters[2]);
  RigidTransform t;
  const double angle = omega.norm();
  if (angle > 0) t.rotation = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
  t.translation = Eigen::Vector3d(parameters[3], parameters[4], parameters[5]);
  return t;
}

void BoneTransformToParameters(const RigidTransform& transform, double* parameters) {
  const Eigen::AngleAxisd aa(transform.rotation);
  const Eigen::Vector3d omega = aa.angle() * aa.axis();
  for (int i = 0; i < 3; ++i) {
    parameters[i] = omega[i];
    parameters[3 + i] = transform.translation[i];
  }
}

Eigen::Matrix3d RotatedPointJacobian(const double* omega, const Eigen::Vector3d& point) {
  using Jet = ceres::Jet<double, 3>;
  Jet w[3], p[3], out[3];
  for (int i = 0; i < 3; ++i) {
    w[i] = Jet(omega[i], i);
    p[i] = Jet(point[i]);
  }
  ceres::AngleAxisRotatePoint(w, p, out);
  Eigen::Matrix3d jacobian;
  for (int i = 0; i < 3; ++i) jacobian.row(i) = out[i].v.transpose();
  return jacobian;
}

}  // namespace aqs
