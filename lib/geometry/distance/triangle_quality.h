#ifndef AQS_GEOMETRY_DISTANCE_TRIANGLE_QUALITY_H_
#define AQS_GEOMETRY_DISTANCE_TRIANGLE_QUALITY_H_

#include <Eigen/Core>

namespace aqs {

// The shape quality of the triangle (a, b, c), q = 2 |e1 x e2| / (|e1|^2 + |e2|^2 + |e2 - e1|^2)
// with e1 = b - a, e2 = c - a: scale-free, 1/sqrt(3) for an equilateral triangle and 0 for
// a degenerate one (about the ratio of its smallest height to its longest edge, times 2/3).
// Also its gradient with respect to a, b, c (3 x 3, columns in that order; null: not
// computed). Returns false where an edge vanishes (all three corners at one point).
bool TriangleQuality(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                     double* quality, Eigen::Matrix3d* gradient);

// Its Hessian with respect to a, b, c (9 x 9; rows and columns x y z of each corner in
// that order). Returns false for a degenerate triangle (where |e1 x e2| is not smooth).
bool TriangleQualityHessian(const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                            const Eigen::Vector3d& c, Eigen::Matrix<double, 9, 9>* hessian);

}  // namespace aqs

#endif  // AQS_GEOMETRY_DISTANCE_TRIANGLE_QUALITY_H_
