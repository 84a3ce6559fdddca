#include "fit/latent_fit.h"

#include <algorithm>
#include <memory>
#include <random>
#include <sstream>

#include <ceres/cost_function.h>
#include <ceres/gradient_checker.h>
#include <ceres/manifold.h>
#include <gtest/gtest.h>

#include "prepare/volumetric_targets.h"
#include "testing/finite_difference.h"
#include "train/pretrain.h"
#include "train/synthetic_muscles.h"
#include "train/trainer.h"

namespace aqs {
namespace {

// A small trained model of the synthetic-muscle bar; with_bone: its fixed end is a bone.
ActiveModel TrainedModel(bool with_bone) {
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(8, 0, 0.3, 21);
  ActiveModel model = data.model;
  std::ostringstream log;
  std::string error;
  EXPECT_TRUE(MakeVolumetricTargets(VolumetricTargetOptions(), &model, log, &error)) << error;
  PretrainOptions pretrain;
  pretrain.spec.latent_dim = 3;
  pretrain.spec.hidden_dims = {16, 16};
  // tanh: a smooth decoder, so that finite differences are exact to high order (ELU is
  // not twice differentiable at 0, which spoils Ridders extrapolation near kinks).
  pretrain.spec.activation = Activation::kTanh;
  pretrain.field.node_spacing = 0.25;
  pretrain.max_iterations = 150;
  pretrain.log_every = 0;
  PretrainReport report;
  EXPECT_TRUE(Pretrain(pretrain, &model, &report, log, &error)) << error;
  if (with_bone) {
    Bone base;
    base.name = "base";
    base.vertices = model.static_vertices;
    base.pose_transforms.assign(model.num_poses(), RigidTransform());
    model.static_vertices.clear();
    model.bones.push_back(base);
  }
  return model;
}

TEST(LatentFitTest, CostJacobianPassesGradientChecker) {
  const ActiveModel model = TrainedModel(true);
  LatentFitOptions options;
  options.solver.relative_force_tolerance = 1e-12;  // Newton reaches round-off
  LatentFitter fitter(model, options);
  // Targets: a few vertices at some positions (their values do not matter for the check).
  std::vector<int> vertices = {3, 20, 41, 57, 77};
  Eigen::Matrix3Xd positions = model.neutral.vertices(Eigen::all, vertices);
  const FitTarget target = VertexTarget(vertices, positions);
  std::unique_ptr<ceres::CostFunction> cost(fitter.NewCostFunction(target));
  ASSERT_EQ(cost->parameter_block_sizes().size(), 2u);
  Eigen::VectorXd z = model.latents.col(2);
  double bone[6] = {0.05, -0.03, 0.02, 0.01, 0.02, -0.01};
  const double* parameters[2] = {z.data(), bone};
  ceres::NumericDiffOptions numeric_options;
  numeric_options.ridders_relative_initial_step_size = 1e-3;
  const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
  ceres::GradientChecker checker(cost.get(), no_manifolds, numeric_options);
  ceres::GradientChecker::ProbeResults results;
  checker.Probe(parameters, 1e-6, &results);
  // Entry-wise relative errors flag exact zeros (rigid translations leave some residual
  // components unchanged): compare each block relative to its largest entry instead.
  ASSERT_EQ(results.jacobians.size(), 2u);
  for (int block = 0; block < 2; ++block) {
    EXPECT_LT(testing::RelativeError(results.jacobians[block], results.numeric_jacobians[block]),
              1e-6)
        << "block " << block << "\n" << results.error_log;
  }
}

TEST(LatentFitTest, TrialEvaluationsDoNotChangeLaterOnes) {
  // An evaluation without Jacobians (a trial point of Ceres' trust region, accepted or
  // not) must not become the start of the next solve: evaluating p1, then a far p2,
  // then p1 again gives p1's residuals bit for bit.
  const ActiveModel model = TrainedModel(true);
  LatentFitter fitter(model, LatentFitOptions());
  std::vector<int> vertices = {3, 20, 41, 57, 77};
  const FitTarget target = VertexTarget(vertices, model.neutral.vertices(Eigen::all, vertices));
  std::unique_ptr<ceres::CostFunction> cost(fitter.NewCostFunction(target));
  Eigen::VectorXd z1 = model.latents.col(2), z2 = model.latents.col(5);
  double bone1[6] = {0.05, -0.03, 0.02, 0.01, 0.02, -0.01}, bone2[6] = {-0.2, 0.1, 0.0, 0.1, 0, 0};
  const double* p1[2] = {z1.data(), bone1};
  const double* p2[2] = {z2.data(), bone2};
  const int n = cost->num_residuals();
  Eigen::VectorXd first(n), far(n), again(n);
  ASSERT_TRUE(cost->Evaluate(p1, first.data(), nullptr));
  ASSERT_TRUE(cost->Evaluate(p2, far.data(), nullptr));
  ASSERT_TRUE(cost->Evaluate(p1, again.data(), nullptr));
  EXPECT_GT((far - first).norm(), 1e-3);
  EXPECT_EQ((again - first).cwiseAbs().maxCoeff(), 0.0);
}

TEST(LatentFitTest, RecoversAKnownLatentFromAnotherStart) {
  const ActiveModel model = TrainedModel(false);
  LatentFitOptions options;
  options.latent_regularization = 0.0;
  options.solver.relative_force_tolerance = 1e-10;
  LatentFitter fitter(model, options);
  const Eigen::VectorXd truth = 0.5 * (model.latents.col(1) + model.latents.col(4));
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(truth, &state, &surface, &error)) << error;
  LatentFitResult fit;
  ASSERT_TRUE(fitter.Fit(FullSurfaceTarget(surface), model.latents.col(6), &fit, &error)) << error;
  EXPECT_LT(fit.max_error, 1e-6) << fit.message;
  EXPECT_LT((fit.surface - surface).cwiseAbs().maxCoeff(), 1e-6);
}

TEST(LatentFitTest, RecoversLatentAndBoneMotion) {
  const ActiveModel model = TrainedModel(true);
  LatentFitOptions options;
  options.latent_regularization = 0.0;
  options.solver.relative_force_tolerance = 1e-10;
  LatentFitter fitter(model, options);
  RigidTransform moved;
  moved.rotation = Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
  moved.translation = Eigen::Vector3d(0.05, -0.1, 0.03);
  fitter.set_bone_transforms({moved});
  const Eigen::VectorXd truth = model.latents.col(3);
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(truth, &state, &surface, &error)) << error;
  fitter.set_bone_transforms({RigidTransform()});  // start the fit at rest
  LatentFitResult fit;
  ASSERT_TRUE(fitter.Fit(FullSurfaceTarget(surface), fitter.MeanLatent(), &fit, &error)) << error;
  EXPECT_LT(fit.max_error, 1e-5) << fit.message;
  ASSERT_EQ(fit.bones.size(), 1u);
  EXPECT_LT((fit.bones[0].rotation - moved.rotation).norm(), 1e-5);
  EXPECT_LT((fit.bones[0].translation - moved.translation).norm(), 1e-5);
}

TEST(LatentFitTest, PointCloudFitRecoversPoseFromPartialNoisyShuffledScan) {
  const ActiveModel model = TrainedModel(false);
  LatentFitOptions options;
  LatentFitter fitter(model, options);
  const Eigen::VectorXd truth = model.latents.col(5);
  Eigen::Matrix3Xd state, surface;
  std::string error;
  ASSERT_TRUE(fitter.Simulate(truth, &state, &surface, &error)) << error;
  // Sample only the triangles of the far half (x > 1 at rest), noisy, shuffled, plus
  // outliers.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.003);
  std::vector<Eigen::Vector3d> samples;
  const Eigen::Matrix3Xi& tris = model.neutral.triangles;
  for (Eigen::Index t = 0; t < tris.cols(); ++t) {
    if (model.neutral.vertices(0, tris(0, t)) < 1.0) continue;
    for (int s = 0; s < 3; ++s) {
      double a = uniform(rng), b = uniform(rng);
      if (a + b > 1) {
        a = 1 - a;
        b = 1 - b;
      }
      const Eigen::Vector3d p = (1 - a - b) * surface.col(tris(0, t)) + a * surface.col(tris(1, t)) +
                                b * surface.col(tris(2, t));
      samples.push_back(p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
    }
  }
  for (int i = 0; i < 10; ++i) samples.push_back(Eigen::Vector3d(5 + i, -3, 2));  // outliers
  std::shuffle(samples.begin(), samples.end(), rng);
  Eigen::Matrix3Xd points(3, samples.size());
  for (size_t i = 0; i < samples.size(); ++i) points.col(i) = samples[i];
  PointCloudFitOptions cloud;
  cloud.max_distance = 0.5;
  cloud.robust_scale = 0.05;
  LatentFitResult fit;
  ASSERT_TRUE(fitter.FitPointCloud(points, cloud, fitter.MeanLatent(), &fit, &error)) << error;
  EXPECT_EQ(fit.used_points, static_cast<int>(samples.size()) - 10) << "outliers left out";
  // The whole surface (also the unscanned half) comes back close to the truth.
  const double vertex_error = (fit.surface - surface).colwise().norm().mean();
  const double motion = (surface - model.neutral.vertices).colwise().norm().mean();
  EXPECT_LT(vertex_error, 0.1 * motion) << "mean vertex error " << vertex_error << " vs motion " << motion;
  EXPECT_LT(fit.mean_error, 0.01);
}

}  // namespace
}  // namespace aqs
