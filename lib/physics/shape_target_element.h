#ifndef AQS_PHYSICS_SHAPE_TARGET_ELEMENT_H_
#define AQS_PHYSICS_SHAPE_TARGET_ELEMENT_H_

#include <Eigen/Core>

#include "physics/actuation.h"
#include "physics/polar.h"

namespace aqs {

// The shape-targeting energy density of one element and its derivatives:
//
//   Psi(F, S) = mu min_{R in SO(3)} ||F - R S||_F^2,
//
// F the 3x3 deformation gradient, S the symmetric 3x3 shape target, mu > 0. The
// minimizing R is the polar rotation of G = F S.
//
// Vectorization: 3x3 matrices are vectorized ROW-MAJOR, vec(F)[3 a + b] = F(a, b),
// matching the residual order of ShapeTargetCostFunction. 9x9 matrices act on such
// vectors. Actuation derivatives are with respect to the six numbers
// (sxx, syy, szz, sxy, sxz, syz) (see physics/actuation.h).
using Matrix9d = Eigen::Matrix<double, 9, 9>;
using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix96d = Eigen::Matrix<double, 9, 6>;

// Row-major vectorization of a 3x3 matrix and its inverse.
Vector9d VecRowMajor(const Eigen::Matrix3d& m);
Eigen::Matrix3d UnvecRowMajor(const Vector9d& v);

// The quantities at one (F, S) that all derivatives share, computed once.
class ShapeTargetElement {
 public:
  ShapeTargetElement(const Eigen::Matrix3d& f, const Eigen::Matrix3d& s, double mu);
  // The same with the rotation-variant SVD of F S given (it must be that of f * s, e.g.
  // from a PolarCache at this state).
  ShapeTargetElement(const Eigen::Matrix3d& f, const Eigen::Matrix3d& s, double mu,
                     const RotationVariantSvd& svd);

  const Eigen::Matrix3d& f() const { return f_; }
  const Eigen::Matrix3d& s() const { return s_; }
  double mu() const { return mu_; }
  // The polar rotation R of F S.
  const Eigen::Matrix3d& rotation() const { return r_; }
  const RotationVariantSvd& svd() const { return svd_; }
  const PolarTwists& twists() const { return twists_; }

  // F - R S (the unscaled residual).
  Eigen::Matrix3d Deviation() const { return f_ - r_ * s_; }
  // Psi = mu ||F - R S||^2 (>= 0, computed directly, no cancellation).
  double EnergyDensity() const;
  // First Piola stress P = dPsi/dF = 2 mu (F - R S).
  Eigen::Matrix3d Stress() const;
  // dP/dF (9x9, symmetric) = 2 mu (I - sum_k gain_k w_k w_k^T), w_k = vec(twist_k S).
  // Exact (up to the degenerate clamp of PolarTwists); indefinite under compression.
  Matrix9d StressDerivative() const;
  // dP/dF with its negative eigenvalues set to zero (positive semi-definite; equal
  // to StressDerivative() where that is already PSD). The 9x9 eigenproblem reduces to
  // a 3x3 one on span{w_k}, on whose complement dP/dF is 2 mu I.
  Matrix9d ProjectedStressDerivative() const;
  // The Jacobian of vec(F - R S) with respect to vec(F): I - sum gain_k w_k w_k^T
  // (= StressDerivative() / (2 mu)).
  Matrix9d DeviationJacobian() const;

  // dPsi/dS for the six actuation numbers: the matrix gradient 2 mu (S - sym(R^T F)),
  // off-diagonal entries counted twice.
  Vector6d EnergyActuationGradient() const;
  // dP/dS (9 x 6): column k is vec(dP/dS [E_k]) with E_k the unit direction of
  // actuation number k:  dP/dS [dS] = -2 mu (dR[F dS] S + R dS).
  Matrix96d StressActuationDerivative() const;
  // The row vector X : dP/dS for a 3x3 X, i.e. (<X, dP/dS [E_k]>)_k, without
  // forming the 9x6 matrix (used by the adjoint gradient).
  Vector6d StressActuationAdjoint(const Eigen::Matrix3d& x) const;
  // dP/dS [dS] for one symmetric direction dS (used by Jacobian-vector products).
  Eigen::Matrix3d StressActuationDirectional(const Eigen::Matrix3d& ds) const;

 private:
  Eigen::Matrix3d f_;
  Eigen::Matrix3d s_;
  double mu_;
  RotationVariantSvd svd_;
  Eigen::Matrix3d r_;
  PolarTwists twists_;
};

}  // namespace aqs

#endif  // AQS_PHYSICS_SHAPE_TARGET_ELEMENT_H_
