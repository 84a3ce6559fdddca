#ifndef AQS_FIT_LATENT_FIT_H_
#define AQS_FIT_LATENT_FIT_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "diff/equilibrium_differentiator.h"
#include "equilibrium/quasistatic_solver.h"
#include "model/active_model.h"

namespace aqs {

struct LatentFitOptions {
  // Residual sqrt(latent_regularization) z added to the data residuals (the prior the
  // latents were trained with, in the same units: the data term is the mean squared
  // distance over the target points).
  double latent_regularization = 1e-3;
  int max_iterations = 50;
  QuasistaticSolverOptions solver;
  int num_threads = 2;
};

// What to fit: surface vertex indices (into the neutral's vertices) and the positions
// they should take (3 x count). Optional per-point weights (empty: all 1).
struct FitTarget {
  std::vector<int> vertices;
  Eigen::Matrix3Xd positions;
  Eigen::VectorXd weights;
};

// All surface vertices at `surface` (3 x num_surface_vertices).
FitTarget FullSurfaceTarget(const Eigen::Matrix3Xd& surface);

struct LatentFitResult {
  Eigen::VectorXd latent;
  Eigen::Matrix3Xd state;    // the equilibrium (3 x num_vertices)
  Eigen::Matrix3Xd surface;  // the simulated surface (3 x num_surface_vertices)
  // Distances between the fitted surface points and the targets.
  double rms_error = 0.0, mean_error = 0.0, max_error = 0.0;
  int iterations = 0;
  bool converged = false;
  std::string message;
};

// Fits the latent of a trained model to target points with the decoder fixed:
//
//   min_z  (1/K) sum_k w_k |p_{v_k}(x*(a(z))) - y_k|^2 + latent_regularization |z|^2,
//
// as a Ceres least-squares problem (Levenberg-Marquardt over the latent_dim numbers of
// z) whose Jacobian comes from implicit differentiation: d p / d z = B dx*/da da/dz,
// with da/dz from the decoder's forward-mode Jacobian and dx*/da [da/dz] from
// Jacobian-vector products with one stiffness factorization (latent_dim solves).
// Bones stay at rest unless set with set_bone_transforms. Equilibria are warm-started
// from the last fit. The model must outlive the fitter.
class LatentFitter {
 public:
  LatentFitter(const ActiveModel& model, const LatentFitOptions& options);
  ~LatentFitter();

  void set_bone_transforms(const std::vector<RigidTransform>& transforms);

  // Fits from `initial` (latent_dim). Returns false with *error if the equilibrium cannot
  // be computed at the start.
  bool Fit(const FitTarget& target, const Eigen::VectorXd& initial, LatentFitResult* result,
           std::string* error);

  // The equilibrium and surface for latent z (with the current bone transforms).
  bool Simulate(const Eigen::VectorXd& z, Eigen::Matrix3Xd* state, Eigen::Matrix3Xd* surface,
                std::string* error);

  // The mean of the training latents (a neutral starting point).
  Eigen::VectorXd MeanLatent() const;

 private:
  class FitCost;
  const ActiveModel& model_;
  LatentFitOptions options_;
  std::unique_ptr<ShapeTargetModel> physics_;
  std::unique_ptr<QuasistaticSolver> solver_;
  std::unique_ptr<EquilibriumDifferentiator> differentiator_;
};

}  // namespace aqs

#endif  // AQS_FIT_LATENT_FIT_H_
