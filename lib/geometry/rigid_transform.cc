#include "geometry/rigid_transform.h"

#include <glog/logging.h>

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <Eigen/SVD>
#include <cmath>

namespace aqs {

Eigen::Matrix3Xd RigidTransform::Apply(const Eigen::Matrix3Xd& points) const {
  return (rotation * points).colwise() + translation;
}

RigidTransform RigidTransform::Inverse() const {
  RigidTransform inverse;
  inverse.rotation = rotation.transpose();
  inverse.translation = -(rotation.transpose() * translation);
  return inverse;
}

RigidTransform FitRigidTransform(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to,
                                 double* rms_residual) {
  return FitRigidTransform(from, to, Eigen::VectorXd::Ones(from.cols()), rms_residual);
}

RigidTransform FitRigidTransform(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to,
                                 const Eigen::VectorXd& weights, double* rms_residual) {
  const Eigen::Index num_points = from.cols();
  CHECK_GE(num_points, 1) << "FitRigidTransform needs at least one point";
  CHECK_EQ(to.cols(), num_points) << "FitRigidTransform: point counts differ";
  CHECK_EQ(weights.size(), num_points) << "FitRigidTransform: one weight per point";
  CHECK(weights.allFinite() && (weights.array() >= 0).all())
      << "FitRigidTransform: weights must be finite and non-negative";
  const double total = weights.sum();
  CHECK_GT(total, 0) << "FitRigidTransform: the weights sum to zero";

  const Eigen::Vector3d from_centroid = from * weights / total;
  const Eigen::Vector3d to_centroid = to * weights / total;
  const Eigen::Matrix3Xd a = from.colwise() - from_centroid;
  const Eigen::Matrix3Xd b = to.colwise() - to_centroid;
  // H = sum_i w_i a_i b_i^T.
  const Eigen::Matrix3d h = a * weights.asDiagonal() * b.transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d& u = svd.matrixU();
  const Eigen::Matrix3d& v = svd.matrixV();
  Eigen::Vector3d signs(1, 1, (v * u.transpose()).determinant() < 0 ? -1 : 1);

  RigidTransform transform;
  transform.rotation = v * signs.asDiagonal() * u.transpose();
  transform.translation = to_centroid - transform.rotation * from_centroid;
  if (rms_residual != nullptr) {
    const Eigen::VectorXd squared = (transform.Apply(from) - to).colwise().squaredNorm();
    *rms_residual = std::sqrt(squared.dot(weights) / total);
  }
  return transform;
}

RigidTransform InterpolateRigidTransform(const RigidTransform& transform, double t) {
  const Eigen::AngleAxisd rotation(transform.rotation);
  RigidTransform result;
  if (std::abs(rotation.angle()) < 1e-12) {
    result.translation = t * transform.translation;
    return result;
  }
  const Eigen::Vector3d axis = rotation.axis();
  const Eigen::Vector3d along = axis.dot(transform.translation) * axis;
  // (I - R) is invertible on the plane normal to the axis; its minimum-norm solution.
  const Eigen::Matrix3d i_minus_r = Eigen::Matrix3d::Identity() - transform.rotation;
  const Eigen::Vector3d centre =
      i_minus_r.jacobiSvd(Eigen::ComputeFullU | Eigen::ComputeFullV)
          .setThreshold(1e-10)
          .solve(transform.translation - along);
  result.rotation = Eigen::AngleAxisd(t * rotation.angle(), axis).toRotationMatrix();
  result.translation = centre - result.rotation * centre + t * along;
  return result;
}

}  // namespace aqs
