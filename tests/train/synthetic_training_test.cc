// The learning pipeline on a body whose poses come from three known muscles:
// volumetric targets, pre-training, end-to-end training through the simulator, then
// fitting held-out poses, compared with a linear (PCA) model of the same latent size.

#include <algorithm>
#include <cstdio>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "eval/surface_pca.h"
#include "fit/latent_fit.h"
#include "prepare/volumetric_targets.h"
#include "testing/synthetic_muscles.h"
#include "train/pretrain.h"
#include "train/trainer.h"

namespace aqs {
namespace {

double MeanDistance(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  return (a - b).colwise().norm().mean();
}

// Mean surface error over `surfaces` of `model` fitted to each (full correspondence,
// from the mean training latent).
double HeldOutFitError(const ActiveModel& model, const std::vector<Eigen::Matrix3Xd>& surfaces) {
  LatentFitter fitter(model, LatentFitOptions());
  double error_sum = 0;
  for (const Eigen::Matrix3Xd& surface : surfaces) {
    LatentFitResult fit;
    std::string error;
    EXPECT_TRUE(fitter.Fit(FullSurfaceTarget(surface), fitter.MeanLatent(), &fit, &error)) << error;
    error_sum += fit.mean_error;
  }
  return error_sum / surfaces.size();
}

TEST(SyntheticTrainingTest, TrainingBeatsItsPretrainedStartAndTheLinearBaselineOnHeldOut) {
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

  // The pre-trained model on the held-out poses: what end-to-end training must improve.
  const double pretrained_error = HeldOutFitError(model, data.test_surfaces);

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
  const double physics_error = HeldOutFitError(model, data.test_surfaces);
  double pca_error = 0, largest_motion = 0;
  for (const Eigen::Matrix3Xd& surface : data.test_surfaces) {
    pca_error += MeanDistance(pca.Decode(pca.Encode(surface)), surface) / data.test_surfaces.size();
    largest_motion = std::max(largest_motion, (surface - model.neutral.vertices).colwise().norm().maxCoeff());
  }
  std::printf(
      "synthetic muscles: training mean surface error %.2e (after pre-training %.2e); held-out "
      "mean error physics %.2e (pre-trained %.2e) vs PCA-3 %.2e (poses move up to %.3f; bar length %.1f)\n",
      report.mean_surface_error, report.initial_mean_surface_error,
      physics_error, pretrained_error, pca_error, largest_motion, bar_length);
  EXPECT_LT(physics_error, pretrained_error) << log.str();
  EXPECT_LT(physics_error, pca_error) << log.str();
}

}  // namespace
}  // namespace aqs
