#include "fit_flags.h"

#include <algorithm>

#include <gflags/gflags.h>

#include "app_common.h"

DEFINE_double(max_distance, 1.0, "Points: ignore scan points farther than this from the surface.");
DEFINE_double(robust_scale, 0.2, "Points: Cauchy scale of the robust weights (0: none).");
DEFINE_bool(match_rounds, false, "Points: fit in rounds of matching with fixed "
            "correspondences (--rounds, --round_iterations, --round_tolerance, "
            "--tangential_weight) instead of one solve whose closest points are found again at "
            "every evaluation.");
DEFINE_int32(rounds, 8, "Points, with --match_rounds: matching rounds.");
DEFINE_double(tangential_weight, 0.2, "Points, with --match_rounds: weight of the distance along "
              "the matched triangle's plane (point-to-plane matching; 1: point-to-point).");
DEFINE_double(round_tolerance, 1e-3, "Points, with --match_rounds: stop when a round changes the "
              "mean matched distance by less than this fraction.");
DEFINE_int32(round_iterations, 6, "Points, with --match_rounds: Levenberg-Marquardt iterations "
             "per matching round.");
DEFINE_double(landmark_weight, 0.03, "Points with landmarks: weight of the landmarks' mean "
              "squared distance against the scan's (1: as much as all scan points). 0.03 "
              "suits a face tracker's 10 landmarks (0.1 cm errors), 1 many precise markers "
              "(60, 0.02 cm; docs/fitting.md).");
DEFINE_double(scan_bone_prior, 0.1, "Points: the bone prior's weight in scan fits (< 0: "
              "--bone_prior's), centred on the bones the fit starts from (the chosen training "
              "pose's, or the previous frame's) rather than on the prior's centre.");
DEFINE_double(scan_latent_prior, 0.01, "Points: the latent prior's weight in scan fits (< 0: "
              "--latent_prior's). Lower than the other fits': a scan's distances stay small "
              "where the surface slides along it (docs/fitting.md).");
DEFINE_bool(choose_start, true, "Start from the best of the given start (prior centre or "
            "--initial_latent) and the training poses, by the fit's objective.");
DEFINE_bool(retry_from_given, true, "With --choose_start: a fit from a training pose that "
            "fails, does not converge or moves a bone beyond the training poses' is fitted "
            "again from the given start, and the fit of the smaller objective kept.");
DEFINE_double(temporal_prior, 0.0, "Sequences with warm starts: also pull each frame toward the "
              "previous frame's latent and bone motions, with this weight (as --latent_prior's: "
              "squared length per point per standard deviation of the training spread). Damps "
              "the jitter of noisy markers (docs/fitting.md). 0: off.");
DEFINE_string(start_latent, "prior", "The given start: 'prior' (the latent prior's centre) or "
              "'mean' (the mean training latent).");

namespace aqs {

bool FitOptionsFromFlags(LatentFitOptions* fit, PointCloudFitOptions* points,
                         FitStartOptions* start, std::string* error) {
  // The values are checked by the options' Validate (the jobs call it; FitFlagNames
  // names the flags in its messages).
  if (!LatentFitOptionsFromFlags(fit, error)) return false;
  points->max_distance = FLAGS_max_distance;
  points->robust_scale = FLAGS_robust_scale;
  points->rematch_every_evaluation = !FLAGS_match_rounds;
  points->max_rounds = FLAGS_rounds;
  points->tangential_weight = FLAGS_tangential_weight;
  points->relative_tolerance = FLAGS_round_tolerance;
  points->iterations_per_round = FLAGS_round_iterations;
  points->landmark_weight = FLAGS_landmark_weight;
  points->bone_prior = FLAGS_scan_bone_prior;
  points->latent_prior = FLAGS_scan_latent_prior;
  start->training_poses = FLAGS_choose_start;
  start->retry_from_given = FLAGS_retry_from_given;
  if (FLAGS_start_latent != "prior" && FLAGS_start_latent != "mean") {
    *error = "--start_latent must be prior or mean, got '" + FLAGS_start_latent + "'";
    return false;
  }
  start->mean_latent = FLAGS_start_latent == "mean";
  return true;
}

double TemporalPriorFlag() { return FLAGS_temporal_prior; }

FlagNames FitFlagNames() {
  FlagNames flags = LatentFitFlagNames("fit.");
  flags.insert(flags.end(), {{"target_kind", "--target_kind"},
                             {"points.max_distance", "--max_distance"},
                             {"points.robust_scale", "--robust_scale"},
                             {"points.max_rounds", "--rounds"},
                             {"points.iterations_per_round", "--round_iterations"},
                             {"points.relative_tolerance", "--round_tolerance"},
                             {"points.tangential_weight", "--tangential_weight"},
                             {"points.landmark_weight", "--landmark_weight"},
                             {"points.bone_prior", "--scan_bone_prior"},
                             {"points.latent_prior", "--scan_latent_prior"},
                             {"temporal_prior", "--temporal_prior"},
                             {"compare_vertices", "--compare_vertices"},
                             {"error_vertices", "--error_vertices"}});
  return flags;
}

}  // namespace aqs
