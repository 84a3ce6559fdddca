#ifndef AQS_PHYSICS_ACTUATION_H_
#define AQS_PHYSICS_ACTUATION_H_

#include <Eigen/Core>

namespace aqs {

// Per-element actuations: a symmetric 3x3 shape target S per element, stored as six
// numbers in the order (sxx, syy, szz, sxy, sxz, syz). Column e of an ActuationMatrix
// (6 x num_elements, column-major, so element e starts at data() + 6 e) is element e.
// S = I is the passive rest state.
using Vector6d = Eigen::Matrix<double, 6, 1>;
using ActuationMatrix = Eigen::Matrix<double, 6, Eigen::Dynamic>;

// The 6-vector of S = I.
inline Vector6d IdentityActuation() {
  Vector6d a;
  a << 1, 1, 1, 0, 0, 0;
  return a;
}

// num_elements columns of IdentityActuation().
inline ActuationMatrix IdentityActuations(int num_elements) {
  return IdentityActuation().replicate(1, num_elements);
}

// The symmetric matrix of six numbers (sxx, syy, szz, sxy, sxz, syz).
inline Eigen::Matrix3d SymmetricFromActuation(const double* a) {
  Eigen::Matrix3d s;
  s << a[0], a[3], a[4],
       a[3], a[1], a[5],
       a[4], a[5], a[2];
  return s;
}

// The six numbers of a symmetric matrix (its upper triangle; the lower is ignored).
inline Vector6d ActuationFromSymmetric(const Eigen::Matrix3d& s) {
  Vector6d a;
  a << s(0, 0), s(1, 1), s(2, 2), s(0, 1), s(0, 2), s(1, 2);
  return a;
}

// Derivative of a scalar with respect to the six numbers, given its derivative G with
// respect to a general (not necessarily symmetric) 3x3 matrix at a symmetric point:
// diagonal entries G_ii, off-diagonal G_ij + G_ji (an off-diagonal number moves two
// entries of S).
inline Vector6d ActuationGradientFromMatrixGradient(const Eigen::Matrix3d& g) {
  Vector6d a;
  a << g(0, 0), g(1, 1), g(2, 2), g(0, 1) + g(1, 0), g(0, 2) + g(2, 0), g(1, 2) + g(2, 1);
  return a;
}

// The unit direction of S for actuation number k (0..5): E_kk for k < 3, and
// E_ij + E_ji for the off-diagonal numbers.
inline Eigen::Matrix3d ActuationBasisMatrix(int k) {
  Vector6d a = Vector6d::Zero();
  a[k] = 1.0;
  return SymmetricFromActuation(a.data());
}

}  // namespace aqs

#endif  // AQS_PHYSICS_ACTUATION_H_
