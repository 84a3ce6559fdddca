#ifndef AQS_PHYSICS_ELEMENT_GEOMETRY_H_
#define AQS_PHYSICS_ELEMENT_GEOMETRY_H_

#include <Eigen/Core>

namespace aqs {

// The rest shape of a tetrahedron that the energy needs: Dm^-1, with
// Dm = [X1 - X0, X2 - X0, X3 - X0], and the rest volume V = |det Dm| / 6 (> 0).
struct ElementRestShape {
  Eigen::Matrix3d dm_inverse;
  double volume = 0.0;
};

// Rest shape of the tetrahedron (X0, X1, X2, X3). The signed volume must be non-zero
// (CHECK); its sign does not matter (F = Ds Dm^-1 is independent of vertex order).
ElementRestShape ComputeElementRestShape(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                                         const Eigen::Vector3d& x2, const Eigen::Vector3d& x3);

// The gradient weights b_k (columns of a 3x4 matrix) of the element's linear shape
// functions: F = sum_k x_k b_k^T, so dF/dx_k[dx] = dx b_k^T. b_1, b_2, b_3 are the rows
// of Dm^-1 and b_0 = -(b_1 + b_2 + b_3). Consequently, for a first Piola stress P, the
// element's energy gradient at vertex k is V P b_k.
Eigen::Matrix<double, 3, 4> GradientWeights(const Eigen::Matrix3d& dm_inverse);

// F = sum_k x_k b_k^T for vertex positions x0..x3.
Eigen::Matrix3d DeformationGradient(const Eigen::Matrix<double, 3, 4>& weights,
                                    const double* x0, const double* x1, const double* x2,
                                    const double* x3);

// The 12x12 element Hessian V * D^T H D for a 9x9 stress derivative H (row-major
// vec(F), see shape_target_element.h), where D (9x12) maps the four stacked vertex
// displacements [dx0; dx1; dx2; dx3] to vec(dF). Block (k, l) couples vertices k, l.
Eigen::Matrix<double, 12, 12> ElementHessian(const Eigen::Matrix<double, 9, 9>& h,
                                             const Eigen::Matrix<double, 3, 4>& weights,
                                             double volume);

// D (9x12) of ElementHessian: vec(dF) = D [dx0; dx1; dx2; dx3].
Eigen::Matrix<double, 9, 12> DeformationGradientJacobian(
    const Eigen::Matrix<double, 3, 4>& weights);

}  // namespace aqs

#endif  // AQS_PHYSICS_ELEMENT_GEOMETRY_H_
