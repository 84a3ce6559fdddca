#ifndef AQS_GEOMETRY_DISTANCE_EDGE_SINE_H_
#define AQS_GEOMETRY_DISTANCE_EDGE_SINE_H_

#include <Eigen/Core>

namespace aqs {

// |sin angle| between the edges (pb - pa) and (qb - qa), |e1 x e2| / (|e1| |e2|), and its
// gradient with respect to pa, pb, qa, qb (3 x 4, columns in that order; null: not
// computed). Returns false for a degenerate edge.
bool EdgeSine(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb, const Eigen::Vector3d& qa,
              const Eigen::Vector3d& qb, double* sine, Eigen::Matrix<double, 3, 4>* gradient);

// Its Hessian with respect to pa, pb, qa, qb (12 x 12, x y z of each point in turn).
// Returns false for a degenerate edge or parallel edges (where the sine is not smooth).
bool EdgeSineHessian(const Eigen::Vector3d& pa, const Eigen::Vector3d& pb,
                     const Eigen::Vector3d& qa, const Eigen::Vector3d& qb,
                     Eigen::Matrix<double, 12, 12>* hessian);

}  // namespace aqs

#endif  // AQS_GEOMETRY_DISTANCE_EDGE_SINE_H_
