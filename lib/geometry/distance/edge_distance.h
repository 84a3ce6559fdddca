#ifndef AQS_GEOMETRY_DISTANCE_EDGE_DISTANCE_H_
#define AQS_GEOMETRY_DISTANCE_EDGE_DISTANCE_H_

#include <Eigen/Core>

namespace aqs {

// The signed distance between the lines of the edges (pa, pb) and (qa, qb) along their
// common normal, s = n . (pa - qa), n = unit((pb - pa) x (qb - qa)), and its gradient
// with respect to pa, pb, qa, qb (3 x 4, columns in that order; null: not computed).
// Also the parameters of the lines' closest points, pa + u (pb - pa) and qa + v (qb - qa)
// (in [0, 1] where the closest points lie on the edges; null: not computed). Returns
// false when the edges are parallel within min_sine (|sin angle| <= min_sine) or
// degenerate: s is then ill-conditioned.
bool EdgeDistance(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& qa,
                  const Eigen::Vector3d& qb, double min_sine, double* s,
                  Eigen::Matrix<double, 3, 4>* gradient, double* u, double* v);

// Its Hessian with respect to pa, pb, qa, qb (12 x 12; rows and columns x y z of each
// point in that order): s = unit(u x v) . w with u = pb - pa, v = qb - qa, w = pa - qa
// (UnitCrossDotHessian). Returns false for parallel or degenerate edges.
bool EdgeDistanceHessian(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb,
                         const Eigen::Vector3d& qa, const Eigen::Vector3d& qb,
                         Eigen::Matrix<double, 12, 12>* hessian);

}  // namespace aqs

#endif  // AQS_GEOMETRY_DISTANCE_EDGE_DISTANCE_H_
