#ifndef AQS_PHYSICS_POLAR_H_
#define AQS_PHYSICS_POLAR_H_

#include <Eigen/Core>

#include "physics/rotation_variant_svd.h"

namespace aqs {

// The rotation R = U V^T of the polar decomposition G = R H (the closest rotation to
// G, i.e. argmax_R tr(R^T G)). For det G < 0 this is still a proper rotation.
Eigen::Matrix3d PolarRotation(const RotationVariantSvd& svd);

// sigma_i + sigma_j below this fraction of max(sigma_0, 1) is treated as this fraction:
// the polar rotation is not differentiable where sigma_i + sigma_j = 0 (flat or
// inverted elements), and there its derivative is reported finite, as the derivative at
// the clamped value. The floor has an absolute part (G = F S is dimensionless, of order
// 1): relative to sigma_0 alone, an element collapsed to a point (G = 0) had gains of
// 2e106, whose stiffness entries made a shifted adjoint's shift (a multiple of the mean
// diagonal) swamp the whole system.
constexpr double kPolarDegenerateRatio = 1e-6;

// The three twist directions of the polar rotation and their gains, for pairs
// (i, j) = (0, 1), (0, 2), (1, 2):
//   twist[k] = U (e_i e_j^T - e_j e_i^T) V^T / sqrt(2)   (orthonormal, Frobenius)
//   gain[k]  = 2 / (sigma_i + sigma_j)                    (clamped, see above)
// so that the derivative of R(G) in direction dG is
//   dR = sum_k gain[k] <twist[k], dG> twist[k].
struct PolarTwists {
  Eigen::Matrix3d twist[3];
  Eigen::Vector3d gain;
};

PolarTwists ComputePolarTwists(const RotationVariantSvd& svd);

// dR = dR/dG [dG], the directional derivative of PolarRotation at G (3x3 -> 3x3).
Eigen::Matrix3d PolarRotationDerivative(const PolarTwists& twists, const Eigen::Matrix3d& dg);

}  // namespace aqs

#endif  // AQS_PHYSICS_POLAR_H_
