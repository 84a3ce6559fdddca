#ifndef AQS_GEOMETRY_DISTANCE_DISTANCE_DERIVATIVES_H_
#define AQS_GEOMETRY_DISTANCE_DISTANCE_DERIVATIVES_H_

#include <Eigen/Core>

namespace aqs {

// The building blocks of the distances' Hessians (plane_distance.h, edge_distance.h,
// edge_sine.h), each of which is a function of differences of four points.

// [a]x: the cross-product matrix, [a]x b = a x b.
Eigen::Matrix3d CrossProductMatrix(const Eigen::Vector3d& a);

// The Hessian of f = n . w, n = unit(u x v), with respect to (u, v, w) (9 x 9, blocks of
// 3 in that order, x y z each). With m = u x v, N = |m|, P = I - n n^T, w_perp = P w and
// g = w_perp / N (= df/dm):
//   d2f/dm2 = -((n . w) P + w_perp n^T + n w_perp^T) / N^2,   d2f/dm dw = P / N,
// and m is bilinear in (u, v): dm/du = -[v]x, dm/dv = [u]x, d2(g . m)/du dv = -[g]x.
// Returns false if u x v vanishes.
bool UnitCrossDotHessian(const Eigen::Vector3d& u, const Eigen::Vector3d& v,
                         const Eigen::Vector3d& w, Eigen::Matrix<double, 9, 9>* hessian);

// Scatters a Hessian h with respect to k differences of n points (3k x 3k, the DOFs of
// difference a at rows and columns 3a .. 3a + 2) to the Hessian with respect to the
// points (3n x 3n, point j at 3j .. 3j + 2; n = 4 unless given), where difference a is
// sum_j coefficients(a, j) points[j] (coefficients -1, 0 or 1).
template <int kDifferences, int kPoints = 4>
void ScatterDifferenceHessian(const Eigen::Matrix<double, kDifferences, kPoints>& coefficients,
                              const Eigen::Matrix<double, 3 * kDifferences, 3 * kDifferences>& h,
                              Eigen::Matrix<double, 3 * kPoints, 3 * kPoints>* hessian) {
  for (int i = 0; i < kPoints; ++i) {
    for (int j = 0; j < kPoints; ++j) {
      Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
      for (int a = 0; a < kDifferences; ++a) {
        for (int b = 0; b < kDifferences; ++b) {
          const double c = coefficients(a, i) * coefficients(b, j);
          if (c != 0.0) block += c * h.template block<3, 3>(3 * a, 3 * b);
        }
      }
      hessian->template block<3, 3>(3 * i, 3 * j) = block;
    }
  }
}

}  // namespace aqs

#endif  // AQS_GEOMETRY_DISTANCE_DISTANCE_DERIVATIVES_H_
