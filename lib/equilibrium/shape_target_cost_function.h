#ifndef AQS_EQUILIBRIUM_SHAPE_TARGET_COST_FUNCTION_H_
#define AQS_EQUILIBRIUM_SHAPE_TARGET_COST_FUNCTION_H_

#include <Eigen/Core>
#include <ceres/sized_cost_function.h>

namespace aqs {

// Ceres cost function of one shape-targeting element, with analytic Jacobians.
//
// Parameter blocks: the positions of the element's four vertices x0, x1, x2, x3
// (3 doubles each). Residual (9): r = sqrt(2 mu V) vec(F - R S), with F = sum_k x_k b_k^T
// the deformation gradient, S the element's current shape target, R the polar rotation
// of F S, and vec row-major (r[3 a + b] ~ (F - R S)(a, b)). Then 1/2 |r|^2 = V Psi(F, S),
// so a Ceres problem made of these blocks has cost E(x, a) and gradient dE/dx.
//
// Jacobian block k (9x3, row-major as Ceres stores it):
//   dr/dx_k = sqrt(2 mu V) (D_k - sum_t gain_t vec(W_t) (W_t b_k)^T),  W_t = twist_t S,
// where D_k[3 a + b][a] = b_k[b] (see physics/polar.h for twists and gains).
//
// The shape target is read at every evaluation from `actuation` (six numbers sxx syy
// szz sxy sxz syz), which the owner may change in place between solves.
class ShapeTargetCostFunction final : public ceres::SizedCostFunction<9, 3, 3, 3, 3> {
 public:
  // weights: the element's gradient weights (GradientWeights(Dm^-1)); volume V > 0;
  // mu > 0; actuation: pointer to six numbers that outlive this object.
  ShapeTargetCostFunction(const Eigen::Matrix<double, 3, 4>& weights, double volume, double mu,
                          const double* actuation);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Matrix<double, 3, 4> weights_;
  double scale_;  // sqrt(2 mu V)
  const double* actuation_;
};

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_SHAPE_TARGET_COST_FUNCTION_H_
