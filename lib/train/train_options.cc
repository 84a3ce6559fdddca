// TrainOptions::Validate (kept apart from the trainer).

#include "train/trainer.h"
#include "util/option_checks.h"

namespace aqs {

bool TrainOptions::Validate(std::string* error) const {
  std::string solver_error;
  const bool solver_ok = solver.Validate(&solver_error);
  return OptionChecks()
      .InRange("latent_regularization", latent_regularization, 0.0, kMaxRegularization)
      .InRange("decoder_regularization", decoder_regularization, 0.0, kMaxRegularization)
      .InRange("energy_regularization", energy_regularization, 0.0, kMaxRegularization)
      .IntAtLeast("max_iterations", max_iterations, 0)
      .NonNegative("max_seconds", max_seconds)
      .Nested("solver", solver_ok, solver_error)
      .ReachableTolerance("solver.relative_force_tolerance", solver.relative_force_tolerance)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .NonNegative("max_factor_cache_gb", max_factor_cache_gb)
      .InRange("adjoint_tolerance", adjoint_tolerance, 1e-14, 1e-2)
      .InRange("max_step_expansion", max_step_expansion, 1.001, 1e6)
      .IntAtLeast("checkpoint_every", checkpoint_every, 1)
      .IntAtLeast("max_restarts", max_restarts, 0)
      .IntAtLeast("log_every", log_every, 0)
      .IntAtLeast("latent_refit_every", latent_refit_every, 0)
      .IntInRange("latent_refit_iterations", latent_refit_iterations, 0, 1000)
      .Require(latent_refit_every == 0 || latent_refit_iterations > 0,
               "latent_refit_every needs latent_refit_iterations > 0 (refits of 0 "
               "iterations do nothing)")
      .Done(error);
}

}  // namespace aqs
