#ifndef AQS_GEOMETRY_DISTANCE_PLANE_DISTANCE_H_
#define AQS_GEOMETRY_DISTANCE_PLANE_DISTANCE_H_

#include <Eigen/Core>

namespace aqs {

// The signed distance of point p to the plane of the triangle (a, b, c),
// s = n . (p - a), n = unit((b - a) x (c - a)) (positive on the side n points to), and
// its gradient with respect to p, a, b, c (3 x 4, columns in that order; null: not
// computed). Also the barycentric coordinates of p's projection onto the plane (null:
// not computed). Returns false for a degenerate triangle.
bool PlaneDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                   const Eigen::Vector3d& c, double* s, Eigen::Matrix<double, 3, 4>* gradient,
                   Eigen::Vector3d* barycentric);

// Its Hessian with respect to p, a, b, c (12 x 12; rows and columns x y z of each point
// in that order): s = unit(u x v) . w with u = b - a, v = c - a, w = p - a
// (UnitCrossDotHessian). Returns false for a degenerate triangle.
bool PlaneDistanceHessian(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                          const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                          Eigen::Matrix<double, 12, 12>* hessian);

}  // namespace aqs

#endif  // AQS_GEOMETRY_DISTANCE_PLANE_DISTANCE_H_
