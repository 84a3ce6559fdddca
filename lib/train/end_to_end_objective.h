#ifndef AQS_TRAIN_END_TO_END_OBJECTIVE_H_
#define AQS_TRAIN_END_TO_END_OBJECTIVE_H_

#include <memory>
#include <string>
#include <vector>

#include <ceres/first_order_function.h>
#include <Eigen/Core>

#include "diff/equilibrium_differentiator.h"
#include "equilibrium/quasistatic_solver.h"
#include "model/active_model.h"
#include "train/trainer.h"

namespace aqs {

// The end-to-end training objective (see TrainEndToEnd) as a Ceres FirstOrderFunction
// over the flat vector [decoder params (num_parameters); z_1; ...; z_P (latent_dim each)]:
//
//   L = (1/(P N)) sum_p sum_i |p_i(x*(a(z_p))) - y_pi|^2 + lambda (1/P) sum_p |z_p|^2.
//
// Evaluate() decodes all poses, solves their equilibria in parallel (per-thread solvers,
// warm-started from each pose's last state) and, with a gradient, runs one adjoint
// solve per pose and back-propagates through the embedding and the decoder. It returns
// false (a failed step for Ceres) if an equilibrium cannot be reached or its stiffness
// is not positive definite. Not thread-safe (Ceres calls it from one thread).
class EndToEndObjective final : public ceres::FirstOrderFunction {
 public:
  // The model (pre-trained: decoder set) must outlive the objective; its states seed
  // the warm starts.
  EndToEndObjective(const TrainOptions& options, const ActiveModel& model);
  ~EndToEndObjective() override;

  int NumParameters() const override;
  bool Evaluate(const double* parameters, double* cost, double* gradient) const override;

  // The model's current [params; latents] as a flat vector.
  Eigen::VectorXd ModelParameters() const;

  // At the last evaluated point: surface errors (mean and max distance over poses and
  // surface vertices), the per-pose equilibria, and why an evaluation failed.
  double mean_surface_error() const;
  double max_surface_error() const;
  const std::vector<Eigen::Matrix3Xd>& states() const { return states_; }
  const std::string& last_failure() const { return last_failure_; }

 private:
  struct Worker {
    std::unique_ptr<QuasistaticSolver> solver;
    std::unique_ptr<EquilibriumDifferentiator> differentiator;
  };

  const TrainOptions options_;
  const ActiveModel& model_;
  const ShapeTargetModel physics_;
  const int num_params_, latent_dim_, num_poses_;
  std::vector<Eigen::Matrix3Xd> fixed_positions_;
  // Evaluation is logically const for Ceres; these caches change.
  mutable std::vector<Worker> workers_;
  mutable std::vector<Eigen::Matrix3Xd> states_;
  mutable std::vector<double> pose_loss_, pose_mean_, pose_max_;
  mutable std::vector<std::string> failures_;
  mutable std::string last_failure_;
};

}  // namespace aqs

#endif  // AQS_TRAIN_END_TO_END_OBJECTIVE_H_
