#ifndef AQS_PHYSICS_ROTATION_VARIANT_SVD_H_
#define AQS_PHYSICS_ROTATION_VARIANT_SVD_H_

#include <Eigen/Core>

namespace aqs {

// Rotation-variant SVD G = U diag(sigma) V^T of a 3x3 matrix, with det U = det V = +1.
// sigma is sorted sigma_0 >= sigma_1 >= |sigma_2|; only sigma_2 may be negative (when
// det G < 0, i.e. the element is inverted). Hence sigma_i + sigma_j >= 0 for i != j.
// U and V are column-major 3x3 (Eigen default); column i of each belongs to sigma_i.
struct RotationVariantSvd {
  Eigen::Matrix3d u;
  Eigen::Matrix3d v;
  Eigen::Vector3d sigma;
};

// The rotation-variant SVD of g, computed by cyclic Jacobi on G^T G (which gives V),
// then a Givens QR of G V (which gives U and sigma, signed). The result is checked:
// where the QR leaves an off-diagonal entry above kSvdResidualRatio * sigma_0 (nearly
// flat or collapsed elements, where G^T G loses the small singular values), it is
// recomputed by RotationVariantSvdReference. A non-finite g gives NaN in u, v and sigma. About twice as fast as
// Eigen's JacobiSVD on the deformation gradients of a simulation, as accurate
// (reconstruction error a few machine epsilons of |G|).
RotationVariantSvd ComputeRotationVariantSvd(const Eigen::Matrix3d& g);

// The fast path alone: returns false, with *out unspecified, where the result would not
// be accurate (see above). g must be finite.
bool JacobiQrSvd(const Eigen::Matrix3d& g, RotationVariantSvd* out);

// The same decomposition by Eigen's two-sided JacobiSVD (slower; the fallback of
// ComputeRotationVariantSvd, and its reference in tests).
RotationVariantSvd RotationVariantSvdReference(const Eigen::Matrix3d& g);

// The largest off-diagonal entry of U^T G V the fast path accepts, relative to sigma_0.
constexpr double kSvdResidualRatio = 1e-14;

}  // namespace aqs

#endif  // AQS_PHYSICS_ROTATION_VARIANT_SVD_H_
