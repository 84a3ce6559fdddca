#include "fit_flags.h"

#include <algorithm>

#include <gflags/gflags.h>

#include "app_common.h"

DEFINE_bool(fit_bones, true, "Also fit the model's bone motions (e.g. the jaw).");
DEFINE_double(latent_prior, 0.03, "Weight of the latent prior (the model's prior.txt: a Gaussian "
              "of the training latents, centred on the neutral): the squared distance per target "
              "point (model units^2) that one standard deviation is worth. 0: off.");
DEFINE_double(bone_prior, 0.03, "Weight of the bone-motion prior (prior.txt: a Gaussian of the "
              "training poses' bone motions, centred on rest), in the same units. 0: off.");
DEFINE_double(prior_points_cap, 200, "The priors' weights are divided by the number of target "
              "points, at most this many (correlated points must not make them vanish). 0: no cap.");
DEFINE_double(fit_regularization, 0.0, "Legacy isotropic latent prior |z|^2 (not scaled by the "
              "number of target points). 0: off.");
DEFINE_int32(fit_iterations, 50, "Levenberg-Marquardt iterations (per matching round for points).");
DEFINE_double(fit_function_tolerance, 1e-4, "Levenberg-Marquardt stops when an iteration changes "
              "the cost by less than this fraction.");
DEFINE_double(max_distance, 1.0, "Points: ignore scan points farther than this from the surface.");
DEFINE_double(robust_scale, 0.2, "Points: Cauchy scale of the robust weights (0: none).");
DEFINE_int32(rounds, 8, "Points: matching rounds.");
DEFINE_double(tangential_weight, 0.2, "Points: weight of the distance along the matched "
              "triangle's plane (point-to-plane matching; 1: point-to-point).");
DEFINE_double(round_tolerance, 1e-3, "Points: stop when a round changes the mean matched distance "
              "by less than this fraction.");
DEFINE_int32(round_iterations, 6, "Points: Levenberg-Marquardt iterations per matching round.");
DEFINE_double(fit_tolerance, 1e-6, "Relative force tolerance of the equilibria.");
DEFINE_bool(choose_start, true, "Start from the best of the given start (prior centre or "
            "--initial_latent) and the training poses, by the fit's objective.");
DEFINE_string(start_latent, "prior", "The given start: 'prior' (the latent prior's centre) or "
              "'mean' (the mean training latent).");
DECLARE_int32(threads);

namespace aqs {

bool FitOptionsFromFlags(LatentFitOptions* fit, PointCloudFitOptions* points,
                         FitStartOptions* start, std::string* error) {
  // The values are checked by the options' Validate (the jobs call it; FitFlagNames
  // names the flags in its messages).
  fit->fit_bones = FLAGS_fit_bones;
  fit->latent_prior = FLAGS_latent_prior;
  fit->bone_prior = FLAGS_bone_prior;
  fit->latent_regularization = FLAGS_fit_regularization;
  fit->prior_points_cap = FLAGS_prior_points_cap;
  fit->max_iterations = FLAGS_fit_iterations;
  fit->function_tolerance = FLAGS_fit_function_tolerance;
  fit->solver.relative_force_tolerance = FLAGS_fit_tolerance;
  if (!SolverMethodFromFlag(&fit->solver, error)) return false;
  fit->num_threads = FLAGS_threads;
  points->max_distance = FLAGS_max_distance;
  points->robust_scale = FLAGS_robust_scale;
  points->max_rounds = FLAGS_rounds;
  points->tangential_weight = FLAGS_tangential_weight;
  points->relative_tolerance = FLAGS_round_tolerance;
  points->iterations_per_round = FLAGS_round_iterations;
  start->training_poses = FLAGS_choose_start;
  if (FLAGS_start_latent != "prior" && FLAGS_start_latent != "mean") {
    *error = "--start_latent must be prior or mean, got '" + FLAGS_start_latent + "'";
    return false;
  }
  start->mean_latent = FLAGS_start_latent == "mean";
  return true;
}

FlagNames FitFlagNames() {
  FlagNames flags = CommonFlagNames("fit.");
  flags.insert(flags.end(), {{"target_kind", "--target_kind"},
                             {"fit.latent_prior", "--latent_prior"},
                             {"fit.bone_prior", "--bone_prior"},
                             {"fit.prior_points_cap", "--prior_points_cap"},
                             {"fit.latent_regularization", "--fit_regularization"},
                             {"fit.max_iterations", "--fit_iterations"},
                             {"fit.function_tolerance", "--fit_function_tolerance"},
                             {"fit.solver.relative_force_tolerance", "--fit_tolerance"},
                             {"points.max_distance", "--max_distance"},
                             {"points.robust_scale", "--robust_scale"},
                             {"points.max_rounds", "--rounds"},
                             {"points.iterations_per_round", "--round_iterations"},
                             {"points.relative_tolerance", "--round_tolerance"},
                             {"points.tangential_weight", "--tangential_weight"}});
  return flags;
}

}  // namespace aqs
