// The learning pipeline on a body whose poses come from three known muscles:
// volumetric targets, pre-training, end-to-end training through the simulator, then
// fitting held-out poses, compared with a linear (PCA) model of the same latent size.

#include <cstdio>
#include <sstream>

#include <gtest/gtest.h>

#include "eval/surface_pca.h"
#include "fit/latent_fit.h"
#include "prepare/volumetric_targets.h"
#include "train/pretrain.h"
#include "train/synthetic_muscles.h"
#include "train/trainer.h"

namespace aqs {
namespace {

double MeanDistance(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  return (a - b).colwise().norm().mean();
}

TEST(SyntheticTrainingTest, ReproducesTrainingPosesAndBeatsLinearBaselineOnHeldOut) {
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(16, 8, 0.35, 7);
  ActiveModel& model = data.model;
  std::ostringstream log;
  std::string error;
  VolumetricTargetOptions targets;
  ASSERT_TRUE(MakeVolumetricTargets(targets, &model, log, &error)) << error;
  for (const TrainingPose& pose : model.poses) {
    EXPECT_LT(pose.embedding_max_error, 2e-3) << pose.name << ": embedded simulation misses";
  }

  PretrainOptions pretrain;
  pretrain.spec.latent_dim = 3;
  pretrain.spec.hidden_dims = {32, 32};
  pretrain.field.node_spacing = 0.2;  // one node per lattice vertex: 11 x 3 x 3
  pretrain.max_iterations = 400;
  pretrain.log_every = 0;
  PretrainReport pretrain_report;
  ASSERT_TRUE(Pretrain(pretrain, &model, &pretrain_report, log, &error)) << error;

  TrainOptions train;
  train.max_iterations = 150;
  train.log_every = 0;
  TrainReport report;
  ASSERT_TRUE(TrainEndToEnd(train, &model, &report, log, &error)) << error << "\n" << log.str();
  EXPECT_LT(report.final_loss, report.initial_loss);
  EXPECT_LE(report.iterations, train.max_iterations);
  EXPECT_LE(report.restarts, train.max_restarts);

  const double bar_length = 2.0;
  // Training poses are reproduced closely.
  EXPECT_LT(report.mean_surface_error, 0.005 * bar_length) << log.str();

  // Held-out poses: physics model (latent fit) vs PCA with the same number of components.
  std::vector<Eigen::Matrix3Xd> train_surfaces;
  for (const TrainingPose& pose : model.poses) train_surfaces.push_back(pose.surface);
  const SurfacePca pca(train_surfaces, 3);
  LatentFitOptions fit_options;
  LatentFitter fitter(model, fit_options);
  double physics_error = 0, pca_error = 0, largest_motion = 0;
  for (const Eigen::Matrix3Xd& surface : data.test_surfaces) {
    LatentFitResult fit;
    ASSERT_TRUE(fitter.Fit(FullSurfaceTarget(surface), fitter.MeanLatent(), &fit, &error)) << error;
    physics_error += fit.mean_error / data.test_surfaces.size();
    pca_error += MeanDistance(pca.Decode(pca.Encode(surface)), surface) / data.test_surfaces.size();
    largest_motion = std::max(largest_motion, (surface - model.neutral.vertices).colwise().norm().maxCoeff());
  }
  std::printf(
      "synthetic muscles: training mean surface error %.2e (after pre-training %.2e); held-out "
      "mean error physics %.2e vs PCA-3 %.2e (poses move up to %.3f; bar length %.1f)\n",
      report.mean_surface_error, report.initial_mean_surface_error,
      physics_error, pca_error, largest_motion, bar_length);
  EXPECT_LT(physics_error, pca_error) << log.str();
}

}  // namespace
}  // namespace aqs
