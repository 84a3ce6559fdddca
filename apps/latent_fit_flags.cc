#include "latent_fit_flags.h"

#include <gflags/gflags.h>

DEFINE_bool(fit_bones, true, "Also fit the model's bone motions (e.g. the jaw).");
DEFINE_double(latent_prior, 0.03, "Weight of the latent prior (the model's prior.txt: a Gaussian "
              "of the training latents, centred on the neutral): the squared distance per target "
              "point (model units^2) that one standard deviation is worth. 0: off. Models with a "
              "larger latent fit markers closer at 0.01 (docs/fitting.md).");
DEFINE_double(bone_prior, 0.01, "Weight of the bone-motion prior (prior.txt: a Gaussian of the "
              "training poses' bone motions, centred on rest), in the same units. 0: off.");
DEFINE_double(prior_points_cap, 200, "The priors' weights are divided by the number of target "
              "points, at most this many (correlated points must not make them vanish). 0: no cap.");
DEFINE_double(fit_regularization, 0.0, "Legacy isotropic latent prior |z|^2 (not scaled by the "
              "number of target points). 0: off.");
DEFINE_int32(fit_iterations, 50, "Levenberg-Marquardt iterations of a fit (for points: of the "
             "whole fit; with --match_rounds, --round_iterations per round instead).");
DEFINE_double(fit_function_tolerance, 1e-4, "Levenberg-Marquardt stops when an iteration changes "
              "the cost by less than this fraction.");
DEFINE_int32(fit_coarse_points, 0, "Poses with correspondence: also fit from the same start "
             "to this many of the target's points (farthest apart) and then to all, and keep the "
             "better fit (a second start against local minima; about 3x the time). 0: one fit.");
DEFINE_double(fit_tolerance, 1e-6, "Relative force tolerance of the equilibria.");
DECLARE_int32(threads);

namespace aqs {

bool LatentFitOptionsFromFlags(LatentFitOptions* fit, std::string* error) {
  // The values are checked by LatentFitOptions::Validate (the jobs call it;
  // LatentFitFlagNames names the flags in its messages).
  fit->fit_bones = FLAGS_fit_bones;
  fit->latent_prior = FLAGS_latent_prior;
  fit->bone_prior = FLAGS_bone_prior;
  fit->latent_regularization = FLAGS_fit_regularization;
  fit->prior_points_cap = FLAGS_prior_points_cap;
  fit->max_iterations = FLAGS_fit_iterations;
  fit->function_tolerance = FLAGS_fit_function_tolerance;
  fit->coarse_points = FLAGS_fit_coarse_points;
  fit->solver.relative_force_tolerance = FLAGS_fit_tolerance;
  if (!SolverMethodFromFlag(&fit->solver, error)) return false;
  fit->num_threads = FLAGS_threads;
  return true;
}

FlagNames LatentFitFlagNames(const std::string& prefix) {
  FlagNames flags = CommonFlagNames(prefix);
  flags.insert(flags.end(), {{prefix + "latent_prior", "--latent_prior"},
                             {prefix + "bone_prior", "--bone_prior"},
                             {prefix + "prior_points_cap", "--prior_points_cap"},
                             {prefix + "latent_regularization", "--fit_regularization"},
                             {prefix + "max_iterations", "--fit_iterations"},
                             {prefix + "function_tolerance", "--fit_function_tolerance"},
                             {prefix + "coarse_points", "--fit_coarse_points"},
                             {prefix + "solver.relative_force_tolerance", "--fit_tolerance"}});
  return flags;
}

}  // namespace aqs
