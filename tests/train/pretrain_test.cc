#include "train/pretrain.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <Eigen/SVD>

#include "fit/latent_fit.h"
#include "model/fit_prior.h"
#include "physics/actuation.h"
#include "prepare/volumetric_targets.h"
#include "testing/synthetic_muscles.h"
#include "testing/training_fixtures.h"

namespace aqs {
namespace {

// Pre-training's final loss is the actuation error plus both regularizers, and the
// decoder regularizer (weight decay) leaves the decoder's parameters smaller than
// pre-training without it from the same start.
TEST(PretrainTest, DecoderRegularizationShrinksTheDecoder) {
  testing::SyntheticBarSpec spec;
  spec.pretrain_iterations = 60;
  const ActiveModel plain = testing::PretrainedSyntheticBar(spec);
  spec.decoder_regularization = 1e-3;
  const ActiveModel decayed = testing::PretrainedSyntheticBar(spec);
  ASSERT_TRUE(plain.decoder && decayed.decoder);
  const double plain_norm = plain.decoder_params.norm();
  const double decayed_norm = decayed.decoder_params.norm();
  EXPECT_LT(decayed_norm, 0.9 * plain_norm);
  std::printf("decoder parameters' norm: %.4f without weight decay, %.4f with 1e-3\n", plain_norm,
              decayed_norm);
}

// Pre-training anew drops the fits' prior of the old latents: of another latent size it
// made the next LatentFitter fail a CHECK, and of the same size it centred fits on the
// old latents. Fits learn it from the new latents, as a saved model's prior.txt is.
TEST(PretrainTest, TheFitsPriorOfTheOldLatentsIsDropped) {
  testing::SyntheticBarSpec spec;
  spec.pretrain_iterations = 10;
  ActiveModel model = testing::PretrainedSyntheticBar(spec);
  model.fit_prior = LearnFitPrior(model);
  ASSERT_EQ(model.fit_prior.latent.size(), 2);
  PretrainOptions options = testing::SyntheticPretrainOptions(spec);
  options.spec.latent_dim = 3;
  PretrainReport report;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(Pretrain(options, &model, &report, log, &error)) << error;
  EXPECT_TRUE(model.fit_prior.empty());
  const LatentFitter fitter(model, LatentFitOptions());  // CHECKed the old prior's size
  EXPECT_EQ(fitter.prior().latent.size(), 3);
}

TEST(PretrainTest, ReportedLossIncludesTheDecoderRegularizer) {
  testing::SyntheticBarSpec spec;
  spec.pretrain_iterations = 20;
  spec.decoder_regularization = 1e-3;
  PretrainReport report;
  const ActiveModel model = testing::PretrainedSyntheticBar(spec, &report);
  ASSERT_TRUE(model.decoder);
  const double latent_regularization = PretrainOptions().latent_regularization;
  const double expected =
      report.rms_actuation_error * report.rms_actuation_error +
      latent_regularization * model.latents.squaredNorm() / model.num_poses() +
      1e-3 * model.decoder_params.squaredNorm();
  EXPECT_NEAR(report.final_loss, expected, 1e-10 * expected);
  EXPECT_GT(1e-3 * model.decoder_params.squaredNorm(), 1e-3 * report.final_loss);
}

// The actuation error pre-training fits and reports is an integral over the body: each
// element's |a - S|_F^2 weighed by its volume. On the synthetic bar stretched along its
// length (x -> x + x^2 / (2 L): the far elements have twice the volume of the near ones;
// the bar's own elements are all alike, which hides the weights), the reported rms error
// is the volume-weighted one of the decoded actuations, recomputed here.
TEST(PretrainTest, TheActuationErrorIsWeightedByElementVolume) {
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(3, 0, 0.3, 11);
  ActiveModel& model = data.model;
  const double length = model.mesh.vertices.row(0).maxCoeff();
  const auto stretch = [length](Eigen::Matrix3Xd* x) {
    x->row(0) = x->row(0) + x->row(0).cwiseAbs2() / (2.0 * length);
  };
  stretch(&model.mesh.vertices);
  stretch(&model.neutral.vertices);
  for (TrainingPose& pose : model.poses) stretch(&pose.surface);
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(MakeVolumetricTargets(VolumetricTargetOptions(), &model, log, &error)) << error;
  testing::SyntheticBarSpec spec;
  spec.pretrain_iterations = 15;
  PretrainReport report;
  ASSERT_TRUE(Pretrain(testing::SyntheticPretrainOptions(spec), &model, &report, log, &error))
      << error;
  const int m = model.mesh.num_tets();
  Eigen::VectorXd volume(m);
  for (int e = 0; e < m; ++e) {
    Eigen::Matrix3d edges;
    for (int k = 0; k < 3; ++k) {
      edges.col(k) = model.mesh.vertices.col(model.mesh.tets(k + 1, e)) -
                     model.mesh.vertices.col(model.mesh.tets(0, e));
    }
    volume[e] = std::abs(edges.determinant()) / 6.0;
  }
  ASSERT_GT(volume.maxCoeff(), 1.5 * volume.minCoeff());
  std::vector<ActuationMatrix> decoded;
  DecoderWorkspace workspace;
  model.decoder->DecodeBatch(model.decoder_params.data(), model.latents, &decoded, &workspace);
  double weighted = 0.0, plain = 0.0;
  for (int p = 0; p < model.num_poses(); ++p) {
    for (int e = 0; e < m; ++e) {
      const double squared = (SymmetricFromActuation(decoded[p].col(e).data()) -
                              SymmetricFromActuation(model.poses[p].target.col(e).data()))
                                 .squaredNorm();
      weighted += volume[e] / volume.sum() * squared / model.num_poses();
      plain += squared / m / model.num_poses();
    }
  }
  const double reported = report.rms_actuation_error * report.rms_actuation_error;
  EXPECT_NEAR(reported, weighted, 1e-9 * weighted);
  EXPECT_GT(std::abs(plain - weighted), 1e-3 * weighted) << "the weights make a difference";
}

// A pre-training that stops where L-BFGS stalls before its budget, with every restart
// allowed used, says so (its record then says that more restarts could take it further);
// one that ends by its budget does not.
TEST(PretrainTest, ReportsAStallWithEveryRestartUsed) {
  testing::SyntheticBarSpec spec;
  spec.num_poses = 2;
  spec.hidden = 2;
  spec.latent_dim = 1;
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(spec.num_poses, 0, 0.3, spec.seed);
  std::ostringstream log;
  std::string error;
  VolumetricTargetOptions targets;
  ASSERT_TRUE(MakeVolumetricTargets(targets, &data.model, log, &error)) << error;
  auto pretrain = [&](int iterations, int restarts, PretrainReport* report) {
    ActiveModel model = data.model;
    PretrainOptions options = testing::SyntheticPretrainOptions(spec);
    options.max_iterations = iterations;
    options.max_restarts = restarts;
    return Pretrain(options, &model, report, log, &error);
  };
  PretrainReport stalled;
  ASSERT_TRUE(pretrain(100000, 0, &stalled)) << error;
  ASSERT_LT(stalled.iterations, 100000) << "the test needs a pre-training that stalls";
  EXPECT_TRUE(stalled.stalled_without_restarts) << stalled.termination;
  PretrainReport restarted;
  ASSERT_TRUE(pretrain(100000, 3, &restarted)) << error;
  EXPECT_EQ(restarted.restarts, 3);
  EXPECT_TRUE(restarted.stalled_without_restarts) << restarted.termination;
  EXPECT_GT(restarted.iterations, stalled.iterations);
  PretrainReport budget;
  ASSERT_TRUE(pretrain(stalled.iterations / 2, 0, &budget)) << error;
  EXPECT_FALSE(budget.stalled_without_restarts) << budget.termination;
  std::printf("stalled after %d iterations (%s); with restarts %d iterations, %d restarts\n",
              stalled.iterations, stalled.termination.c_str(), restarted.iterations,
              restarted.restarts);
}

TEST(PretrainTest, DecoderRegularizationIsValidated) {
  PretrainOptions options;
  std::string error;
  for (double bad : {-1.0, std::numeric_limits<double>::infinity()}) {
    options.decoder_regularization = bad;
    EXPECT_FALSE(options.Validate(&error)) << bad;
    EXPECT_NE(error.find("decoder_regularization"), std::string::npos) << error;
  }
}

// --pretrain_latents=surfaces: the latents are the surfaces' whitened principal
// components about the neutral and stay there while the decoder is fitted; pre-training
// lowers the loss all the same. The default (targets) moves them.
TEST(PretrainTest, SurfaceLatentsStartAtTheSurfacesAndAreHeld) {
  testing::SyntheticBarSpec spec;
  spec.pretrain_iterations = 30;
  spec.latent_start = PretrainLatentStart::kSurfaces;
  PretrainReport report;
  const ActiveModel model = testing::PretrainedSyntheticBar(spec, &report);
  ASSERT_TRUE(model.decoder);
  // Independently: the right singular vectors of the displacements from the neutral
  // (3N x P), scaled by sqrt(P - 1), up to each component's sign.
  const int p = model.num_poses();
  Eigen::MatrixXd displacements(3 * model.num_surface_vertices(), p);
  for (int i = 0; i < p; ++i) {
    const Eigen::Matrix3Xd d = model.poses[i].surface - model.neutral.vertices;
    displacements.col(i) = Eigen::Map<const Eigen::VectorXd>(d.data(), d.size());
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(displacements, Eigen::ComputeThinV);
  ASSERT_EQ(model.latents.rows(), spec.latent_dim);
  for (int k = 0; k < spec.latent_dim; ++k) {
    const Eigen::VectorXd expected = svd.matrixV().col(k) * std::sqrt(p - 1.0);
    const Eigen::VectorXd row = model.latents.row(k).transpose();
    const double sign = row.dot(expected) < 0 ? -1.0 : 1.0;
    EXPECT_LT((row - sign * expected).norm(), 1e-8 * expected.norm()) << "component " << k;
  }
  EXPECT_LT(report.final_loss, 0.5 * report.initial_loss);

  spec.latent_start = PretrainLatentStart::kTargets;
  const ActiveModel moved = testing::PretrainedSyntheticBar(spec);
  EXPECT_GT((moved.latents - model.latents).norm(), 1e-3);
}

TEST(PretrainTest, LatentStartNames) {
  PretrainLatentStart start = PretrainLatentStart::kTargets;
  ASSERT_TRUE(PretrainLatentStartFromName("surfaces", &start));
  EXPECT_EQ(start, PretrainLatentStart::kSurfaces);
  EXPECT_STREQ(PretrainLatentStartName(start), "surfaces");
  ASSERT_TRUE(PretrainLatentStartFromName("targets", &start));
  EXPECT_EQ(start, PretrainLatentStart::kTargets);
  EXPECT_FALSE(PretrainLatentStartFromName("Surfaces", &start));
}

}  // namespace
}  // namespace aqs
