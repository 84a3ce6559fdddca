#ifndef AQS_FIT_BONE_PARAMETERS_H_
#define AQS_FIT_BONE_PARAMETERS_H_

#include <Eigen/Core>

#include "geometry/rigid_transform.h"

namespace aqs {

// The 6 numbers by which fits move a bone: a rotation vector omega (axis times angle, in
// radians; parameters[0..2]) and a translation t (parameters[3..5]). The bone's rest
// vertex X goes to R(omega) X + t.

// The transform of `parameters` (6 numbers).
RigidTransform BoneTransformFromParameters(const double* parameters);
// The 6 numbers of `transform` (its rotation's angle in [0, pi]).
void BoneTransformToParameters(const RigidTransform& transform, double* parameters);

// d (R(omega) X) / d omega (3 x 3; row i the derivatives of coordinate i) at omega
// (3 numbers) for the point X, by forward-mode differentiation of Ceres'
// AngleAxisRotatePoint (exact also at omega = 0). With respect to t the derivative is
// the identity.
Eigen::Matrix3d RotatedPointJacobian(const double* omega, const Eigen::Vector3d& point);

}  // namespace aqs

#endif  // AQS_FIT_BONE_PARAMETERS_H_
