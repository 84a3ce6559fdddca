#ifndef AQS_GEOMETRY_RIGID_TRANSFORM_H_
#define AQS_GEOMETRY_RIGID_TRANSFORM_H_

#include <Eigen/Core>

namespace aqs {

// x -> rotation * x + translation, with rotation a proper rotation (orthonormal,
// determinant +1).
struct RigidTransform {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  // The transformed points: column i is rotation * points.col(i) + translation
  // (points: 3 x K; result 3 x K).
  Eigen::Matrix3Xd Apply(const Eigen::Matrix3Xd& points) const;
  // One point.
  Eigen::Vector3d ApplyToPoint(const Eigen::Vector3d& point) const {
    return rotation * point + translation;
  }
  // The inverse transform (rotation^T, -rotation^T translation).
  RigidTransform Inverse() const;
};

// The rigid transform T minimizing sum_i |T(from.col(i)) - to.col(i)|^2 (Kabsch:
// centre both point sets, SVD of the 3 x 3 cross-covariance H = U S V^T, rotation
// V diag(1, 1, det(V U^T)) U^T, so a reflection is never returned even when it would
// fit better; the translation then maps the centroid of `from` to that of `to`).
// from and to: 3 x K, the same K >= 1 (CHECK). When the points are collinear or
// coincident the rotation about their line (or all rotations) fits equally well, and one
// of the minimizers is returned. If rms_residual is not null it receives
// sqrt(sum_i |T(from_i) - to_i|^2 / K).
RigidTransform FitRigidTransform(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to,
                                 double* rms_residual = nullptr);

// Weighted version: minimizes sum_i weights(i) |T(from_i) - to_i|^2 (weighted centroids
// and cross-covariance). weights: K non-negative numbers with a positive sum (CHECK).
// rms_residual: sqrt(sum_i w_i |T(from_i) - to_i|^2 / sum_i w_i).
RigidTransform FitRigidTransform(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to,
                                 const Eigen::VectorXd& weights, double* rms_residual = nullptr);

// The screw motion from the identity (t = 0) to `transform` (t = 1): the rotation by t
// times its angle about its axis, through the axis' point c that (I - R) c = the
// translation's part normal to the axis, with t times the translation's part along the
// axis (a rotation about a pivot p moves points on arcs around p). Exact at t = 0 and 1;
// a pure translation is scaled by t.
RigidTransform InterpolateRigidTransform(const RigidTransform& transform, double t);

}  // namespace aqs

#endif  // AQS_GEOMETRY_RIGID_TRANSFORM_H_
