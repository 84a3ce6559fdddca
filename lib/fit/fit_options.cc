// Validate() and KeyText() of the fit options (fit/fit_options.h), and CheckPointCloudScales.

#include <cmath>
#include <string>

#include "fit/fit_options.h"
#include "util/number_format.h"
#include "util/option_checks.h"

namespace aqs {

std::string LatentFitOptions::KeyText() const {
  return "priors " + FormatDouble(latent_prior) + " " + FormatDouble(bone_prior) + " " +
         FormatDouble(prior_points_cap) + " " + FormatDouble(latent_regularization) +
         "\nfit " + std::to_string(fit_bones) + " " + std::to_string(max_iterations) + " " +
         FormatDouble(function_tolerance) + " " + FormatDouble(parameter_tolerance) + " " +
         std::to_string(coarse_points) + " " + std::to_string(uncertainty) + "\nsolver " +
         solver.KeyText() + "\n";
}

std::string PointCloudFitOptions::KeyText() const {
  return "points " + std::to_string(max_rounds) + " " + std::to_string(iterations_per_round) +
         " " + FormatDouble(max_distance) + " " + FormatDouble(robust_scale) + " " +
         FormatDouble(relative_tolerance) + " " + FormatDouble(tangential_weight) + " " +
         std::to_string(rematch_every_evaluation) + " " + FormatDouble(landmark_weight) + " " +
         FormatDouble(bone_prior) + " " + FormatDouble(latent_prior) + "\n";
}

bool LatentFitOptions::Validate(std::string* error) const {
  std::string solver_error;
  const bool solver_ok = solver.Validate(&solver_error);
  return OptionChecks()
      .InRange("latent_prior", latent_prior, 0.0, kMaxRegularization)
      .InRange("bone_prior", bone_prior, 0.0, kMaxRegularization)
      .Require(!std::isnan(prior_points_cap) && std::isfinite(prior_points_cap),
               "prior_points_cap must be finite (<= 0: no cap) (is " +
                   OptionValue(prior_points_cap) + ")")
      // The priors are weighted by 1 / min(points, cap): a cap below one point multiplied
      // them (1e-300 made every fit fail in Ceres, naming nothing).
      .Require(!(prior_points_cap > 0 && prior_points_cap < 1),
               "prior_points_cap must be <= 0 (no cap) or >= 1 point (is " +
                   OptionValue(prior_points_cap) + ")")
      .InRange("latent_regularization", latent_regularization, 0.0, kMaxRegularization)
      .IntInRange("max_iterations", max_iterations, 1, 1000000)
      .Positive("function_tolerance", function_tolerance)
      .Positive("parameter_tolerance", parameter_tolerance)
      .IntInRange("coarse_points", coarse_points, 0, 100000000)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .Nested("solver", solver_ok, solver_error)
      .ReachableTolerance("solver.relative_force_tolerance", solver.relative_force_tolerance)
      .Done(error);
}

bool PointCloudFitOptions::Validate(std::string* error) const {
  // max_distance and robust_scale may be 0 (off) or infinite (no cap, no weighting).
  return OptionChecks()
      .IntInRange("max_rounds", max_rounds, 1, 10000)
      .IntInRange("iterations_per_round", iterations_per_round, 1, 1000000)
      .Require(max_distance >= 0.0,
               "max_distance must be >= 0 (0: no cap) (is " + OptionValue(max_distance) + ")")
      .Require(robust_scale >= 0.0,
               "robust_scale must be >= 0 (0: no robust weights) (is " +
                   OptionValue(robust_scale) + ")")
      .NonNegative("relative_tolerance", relative_tolerance)
      .NonNegative("tangential_weight", tangential_weight)
      .InRange("landmark_weight", landmark_weight, 0.0, kMaxRegularization)
      .Require(std::isfinite(bone_prior) && bone_prior <= kMaxRegularization,
               "bone_prior must be finite and at most " + OptionValue(kMaxRegularization) +
                   " (< 0: the other fits' weight) (is " + OptionValue(bone_prior) + ")")
      .Require(std::isfinite(latent_prior) && latent_prior <= kMaxRegularization,
               "latent_prior must be finite and at most " + OptionValue(kMaxRegularization) +
                   " (< 0: the other fits' weight) (is " + OptionValue(latent_prior) + ")")
      .Require(landmarks.vertices.cols() == landmarks.num_points() &&
                   landmarks.barycentric.cols() == landmarks.num_points() &&
                   (landmarks.weights.size() == 0 ||
                    landmarks.weights.size() == landmarks.num_points()),
               "landmarks must give vertices, barycentric coordinates (and weights, if any) "
               "for each of its " + std::to_string(landmarks.num_points()) + " points")
      .Require(landmarks.positions.allFinite(), "landmarks must have finite positions")
      .Done(error);
}

bool CheckPointCloudScales(const PointCloudFitOptions& options, double model_size,
                           std::string* error) {
  const double smallest = kMinPointScaleInModelSizes * model_size;
  const auto on_and_below = [&](double value) { return value > 0.0 && value < smallest; };
  const std::string floor = OptionValue(kMinPointScaleInModelSizes) +
                            " times the model's size (" + OptionValue(model_size) + "): " +
                            OptionValue(smallest);
  return OptionChecks()
      .Require(!on_and_below(options.robust_scale),
               "points.robust_scale must be 0 (no robust weights) or at least " + floor +
                   " (is " + OptionValue(options.robust_scale) +
                   "; smaller, every scan point weighs alike and next to nothing)")
      .Require(!on_and_below(options.max_distance),
               "points.max_distance must be 0 (no cap) or at least " + floor + " (is " +
                   OptionValue(options.max_distance) + ")")
      .Done(error);
}

}  // namespace aqs
