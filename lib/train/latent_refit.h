#ifndef AQS_TRAIN_LATENT_REFIT_H_
#define AQS_TRAIN_LATENT_REFIT_H_

#include <string>
#include <vector>

#include "model/active_model.h"
#include "equilibrium/quasistatic_solver.h"

namespace aqs {

struct LatentRefitOptions {
  // Weight lambda of the latent regularizer, as in training (TrainOptions).
  double latent_regularization = 1e-3;
  // Weight of the equilibrium-energy regularizer, as in training
  // (TrainOptions::energy_regularization): part of the objective a refit must lower.
  double energy_regularization = 0.0;
  // Levenberg-Marquardt iterations per pose.
  int max_iterations = 5;
  QuasistaticSolverOptions solver;  // the equilibria (num_threads: set to 1)
  int num_threads = 2;              // poses refitted in parallel

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

struct LatentRefitReport {
  // The training loss (TrainEndToEnd's L) before and after, from the poses' stored
  // equilibria and the refitted ones, without the decoder's weight decay
  // (TrainOptions::decoder_regularization), which a refit does not change.
  double loss_before = 0.0;
  double loss_after = 0.0;
  int improved = 0;  // poses whose latent changed (their loss went down)
  int failed = 0;    // poses whose fit failed (latent and state kept)
  double seconds = 0.0;
};

// Gauss-Newton steps on the per-pose latents with the decoder fixed: for every
// training pose p of `model` (pre-trained or trained: decoder, latents, bone motions
// and one equilibrium per pose in model->states), lowers the pose's share of the
// training loss over its latent z_p (latent_dim) alone,
//
//   (1/N) sum_i |p_i(x*(a(z_p))) - y_pi|^2 + lambda |z_p|^2
//     + energy_regularization E(x*, a(z_p)) / (sum_e mu_e V_e)
//
// (N surface vertices, the pose's bone motions fixed). Levenberg-Marquardt (LatentFitter,
// full-surface target, no priors) minimizes its first two terms from z_p and its stored
// equilibrium; a pose's latent and state (3 x num_vertices) are replaced only where the
// fit lowered the whole share, the energy term included; a failed fit keeps them. So
// the training loss never goes up. Poses
// run in parallel (options.num_threads, one fitter each). The model's fit prior is not
// used and not changed.
//
// poses (optional, ascending): refit only these; the others' latents and states are
// neither read nor changed, and the report counts these only (its losses are still
// divided by the model's pose count, so that the reports of disjoint subsets add up to
// the whole's: how ranks of a distributed run share the refits).
LatentRefitReport RefitTrainingLatents(const LatentRefitOptions& options, ActiveModel* model,
                                       const std::vector<int>* poses = nullptr);

}  // namespace aqs

#endif  // AQS_TRAIN_LATENT_REFIT_H_
