// LatentFitOptions::KeyText (fit/fit_options.cc), PointCloudFitOptions::KeyText and
// QuasistaticSolverOptions::KeyText:
// every option that changes a fit's result changes the key (stored fits of other options
// are not taken: jobs/held_out_fit_store.h); threads and logging do not.

#include <cmath>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "fit/latent_fit.h"

namespace aqs {
namespace {

using Change = std::pair<const char*, std::function<void(LatentFitOptions*)>>;

TEST(FitOptionsTest, EveryResultShapingOptionChangesTheKey) {
  const LatentFitOptions base;
  const std::vector<Change> changes = {
      {"latent_prior", [](LatentFitOptions* o) { o->latent_prior *= 2; }},
      {"bone_prior", [](LatentFitOptions* o) { o->bone_prior *= 2; }},
      {"prior_points_cap", [](LatentFitOptions* o) { o->prior_points_cap += 1; }},
      {"latent_regularization", [](LatentFitOptions* o) { o->latent_regularization = 1e-3; }},
      {"fit_bones", [](LatentFitOptions* o) { o->fit_bones = !o->fit_bones; }},
      {"max_iterations", [](LatentFitOptions* o) { o->max_iterations += 1; }},
      {"function_tolerance", [](LatentFitOptions* o) { o->function_tolerance *= 0.5; }},
      {"parameter_tolerance", [](LatentFitOptions* o) { o->parameter_tolerance *= 0.5; }},
      {"coarse_points", [](LatentFitOptions* o) { o->coarse_points = 200; }},
      {"uncertainty", [](LatentFitOptions* o) { o->uncertainty = !o->uncertainty; }},
      {"solver.method",
       [](LatentFitOptions* o) { o->solver.method = EquilibriumMethod::kLevenbergMarquardt; }},
      {"solver.relative_force_tolerance",
       [](LatentFitOptions* o) { o->solver.relative_force_tolerance *= 0.5; }},
      {"solver.max_iterations", [](LatentFitOptions* o) { o->solver.max_iterations += 1; }},
      {"solver.max_lbfgs_iterations",
       [](LatentFitOptions* o) { o->solver.max_lbfgs_iterations += 1; }},
      {"solver.lbfgs_reuses_factor",
       [](LatentFitOptions* o) { o->solver.lbfgs_reuses_factor = !o->solver.lbfgs_reuses_factor; }},
      {"solver.lbfgs_reused_factor_stall_iterations",
       [](LatentFitOptions* o) { o->solver.lbfgs_reused_factor_stall_iterations += 1; }},
      {"solver.negative_curvature_steps",
       [](LatentFitOptions* o) {
         o->solver.negative_curvature_steps = !o->solver.negative_curvature_steps;
       }},
      {"solver.ensure_stable",
       [](LatentFitOptions* o) { o->solver.ensure_stable = !o->solver.ensure_stable; }},
      {"solver.ordering",
       [](LatentFitOptions* o) { o->solver.ordering = NormalEquationsOrdering::kDynamic; }},
      {"solver.use_postordering",
       [](LatentFitOptions* o) { o->solver.use_postordering = !o->solver.use_postordering; }},
      {"solver.newton_relative_force",
       [](LatentFitOptions* o) { o->solver.newton_relative_force *= 0.5; }},
      {"solver.factor_reuse.max_iterations",
       [](LatentFitOptions* o) { o->solver.factor_reuse.max_iterations += 1; }},
      {"solver.factor_reuse.relative_tolerance",
       [](LatentFitOptions* o) { o->solver.factor_reuse.relative_tolerance *= 0.5; }},
      {"solver.factor_reuse.probe_iterations",
       [](LatentFitOptions* o) { o->solver.factor_reuse.probe_iterations += 1; }},
      {"solver.factor_reuse.probe_tolerance",
       [](LatentFitOptions* o) { o->solver.factor_reuse.probe_tolerance *= 0.5; }},
      {"solver.factor_reuse.max_columns",
       [](LatentFitOptions* o) { o->solver.factor_reuse.max_columns += 1; }},
      {"solver.factor_reuse.refresh_iterations",
       [](LatentFitOptions* o) { o->solver.factor_reuse.refresh_iterations += 1; }},
      {"solver.function_tolerance",
       [](LatentFitOptions* o) { o->solver.function_tolerance *= 0.5; }},
      {"solver.parameter_tolerance",
       [](LatentFitOptions* o) { o->solver.parameter_tolerance *= 0.5; }},
  };
  for (const auto& [name, change] : changes) {
    LatentFitOptions changed = base;
    change(&changed);
    EXPECT_NE(changed.KeyText(), base.KeyText()) << name;
  }
  // Not part of the key: where and how the work runs.
  LatentFitOptions same = base;
  same.num_threads = 7;
  same.solver.num_threads = 5;
  same.solver.log_progress = true;
  EXPECT_EQ(same.KeyText(), base.KeyText());
  // Doubles exactly: a change in the last bit is another key.
  same = base;
  same.latent_prior = std::nextafter(same.latent_prior, 1.0);
  EXPECT_NE(same.KeyText(), base.KeyText());
}

// The same for scan fits (PointCloudFitOptions::KeyText, the key of stored scan-sequence
// frames): every option changes it; the landmarks (data, fingerprinted per frame) do not.
TEST(FitOptionsTest, EveryScanFitOptionChangesItsKey) {
  using PointsChange = std::pair<const char*, std::function<void(PointCloudFitOptions*)>>;
  const PointCloudFitOptions base;
  const std::vector<PointsChange> changes = {
      {"max_rounds", [](PointCloudFitOptions* o) { o->max_rounds += 1; }},
      {"iterations_per_round", [](PointCloudFitOptions* o) { o->iterations_per_round += 1; }},
      {"max_distance", [](PointCloudFitOptions* o) { o->max_distance *= 0.5; }},
      {"robust_scale", [](PointCloudFitOptions* o) { o->robust_scale *= 0.5; }},
      {"relative_tolerance", [](PointCloudFitOptions* o) { o->relative_tolerance *= 0.5; }},
      {"tangential_weight", [](PointCloudFitOptions* o) { o->tangential_weight *= 0.5; }},
      {"rematch_every_evaluation",
       [](PointCloudFitOptions* o) { o->rematch_every_evaluation = !o->rematch_every_evaluation; }},
      {"landmark_weight", [](PointCloudFitOptions* o) { o->landmark_weight *= 0.5; }},
      {"bone_prior", [](PointCloudFitOptions* o) { o->bone_prior *= 0.5; }},
      {"latent_prior",
       [](PointCloudFitOptions* o) { o->latent_prior = std::nextafter(o->latent_prior, 1.0); }},
  };
  for (const auto& [name, change] : changes) {
    PointCloudFitOptions changed = base;
    change(&changed);
    EXPECT_NE(changed.KeyText(), base.KeyText()) << name;
  }
  PointCloudFitOptions same = base;
  same.landmarks.positions = Eigen::Matrix3Xd::Zero(3, 2);
  EXPECT_EQ(same.KeyText(), base.KeyText());
}

// Robust scales and distance caps are 0 (off) or at least 1e-6 model sizes: below,
// every scan point weighs alike and next to nothing (1e-300 was accepted).
TEST(FitOptionsTest, ScanScalesAreOffOrAtLeastAMillionthOfTheModel) {
  PointCloudFitOptions options;
  std::string error;
  EXPECT_TRUE(CheckPointCloudScales(options, 2.0, &error)) << error;
  options.robust_scale = 0.0;
  options.max_distance = 0.0;
  EXPECT_TRUE(CheckPointCloudScales(options, 2.0, &error)) << error;
  options.robust_scale = 2e-6;  // exactly the floor of a model of size 2
  options.max_distance = 2e-6;
  EXPECT_TRUE(CheckPointCloudScales(options, 2.0, &error)) << error;
  options.robust_scale = 1.9e-6;
  EXPECT_FALSE(CheckPointCloudScales(options, 2.0, &error));
  EXPECT_EQ(error.rfind("points.robust_scale must be 0 (no robust weights) or at least 1e-06 "
                        "times the model's size (2): 2e-06 (is 1.9e-06",
                        0),
            0u)
      << error;
  options.robust_scale = 0.2;
  options.max_distance = 1e-300;
  EXPECT_FALSE(CheckPointCloudScales(options, 2.0, &error));
  EXPECT_EQ(error.rfind("points.max_distance must be 0 (no cap) or at least", 0), 0u) << error;
  // The same scales are fine for a model a million times smaller.
  EXPECT_TRUE(CheckPointCloudScales(options, 1e-300, &error)) << error;
}

}  // namespace
}  // namespace aqs
