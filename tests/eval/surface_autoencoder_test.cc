#include "eval/surface_autoencoder.h"

#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/LU>
#include <gtest/gtest.h>

#include "fit/latent_fit.h"
#include "testing/finite_difference.h"
#include "testing/temp_dir.h"
#include "testing/training_fixtures.h"
#include "util/fault_injection.h"

namespace aqs {
namespace {

// A 6 x 4 grid of points in the plane z = 0 (x in [-1, 1], y in [0, 1]), stretched along
// x by (1 + stretch) and then bent around the y axis with curvature `bend`: the point at
// arc length u = (1 + stretch) x goes to (sin(bend u) / bend, y, (1 - cos(bend u)) / bend).
// A two-parameter nonlinear family of surfaces; 3 x 24.
Eigen::Matrix3Xd BentGrid(double bend, double stretch) {
  constexpr int kNx = 6, kNy = 4;
  Eigen::Matrix3Xd points(3, kNx * kNy);
  for (int j = 0; j < kNy; ++j) {
    for (int i = 0; i < kNx; ++i) {
      const double x = -1.0 + 2.0 * i / (kNx - 1);
      const double y = static_cast<double>(j) / (kNy - 1);
      const double u = (1.0 + stretch) * x;
      points.col(j * kNx + i) << std::sin(bend * u) / bend, y, (1.0 - std::cos(bend * u)) / bend;
    }
  }
  return points;
}

// The 16 training surfaces: bend in {0.2, 0.6, 1.0, 1.4} x stretch in {-0.2, ..., 0.2}.
std::vector<Eigen::Matrix3Xd> TrainingSurfaces() {
  std::vector<Eigen::Matrix3Xd> surfaces;
  for (int a = 0; a < 4; ++a) {
    for (int b = 0; b < 4; ++b) {
      surfaces.push_back(BentGrid(0.2 + 0.4 * a, -0.2 + 0.4 * b / 3.0));
    }
  }
  return surfaces;
}

double RmsDistance(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  return std::sqrt((a - b).colwise().squaredNorm().mean());
}

// The training objective's gradient (network weights and latents) against central
// differences of the objective.
TEST(SurfaceAutoencoderObjectiveTest, GradientMatchesCentralDifferences) {
  for (Activation activation : {Activation::kElu, Activation::kTanh, Activation::kSoftplus}) {
    const int n = 5, d = 3, p = 4;
    const Mlp mlp(MlpSpec{d, {7, 6}, 3 * n, activation});
    std::mt19937 rng(7);
    std::normal_distribution<double> normal(0.0, 1.0);
    Eigen::MatrixXd displacements(3 * n, p);
    for (Eigen::Index i = 0; i < displacements.size(); ++i) displacements.data()[i] = normal(rng);
    const double output_scale = 0.7, lambda = 0.05;
    SurfaceAutoencoderObjective objective(mlp, displacements, output_scale, lambda);
    ASSERT_EQ(objective.NumParameters(), mlp.num_parameters() + d * p);
    Eigen::VectorXd x(objective.NumParameters());
    mlp.InitializeParameters(3, x.data(), 1.0);
    // Non-zero biases, so that every parameter matters.
    for (int l = 0; l < mlp.num_layers(); ++l) {
      for (int i = 0; i < mlp.widths()[l + 1]; ++i) x[mlp.bias_offset(l) + i] = 0.3 * normal(rng);
    }
    for (int i = mlp.num_parameters(); i < x.size(); ++i) x[i] = normal(rng);

    Eigen::VectorXd gradient(x.size());
    double cost = 0;
    ASSERT_TRUE(objective.Evaluate(x.data(), &cost, gradient.data()));
    EXPECT_DOUBLE_EQ(cost, objective.Loss(x.data(), nullptr));
    const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(
        [&](const Eigen::VectorXd& t) { return objective.Loss(t.data(), nullptr); }, x, 1e-4);
    EXPECT_LT(testing::RelativeError(gradient, numeric), 1e-8) << ActivationName(activation);

    // The data term is the mean squared vertex distance: check it directly.
    double mse = 0, max_distance = 0;
    objective.Loss(x.data(), nullptr, &mse, &max_distance);
    MlpWorkspace workspace;
    Eigen::MatrixXd outputs;
    mlp.Forward(x.data(), Eigen::Map<const Eigen::MatrixXd>(x.data() + mlp.num_parameters(), d, p),
                &outputs, &workspace);
    const Eigen::MatrixXd residual = output_scale * outputs - displacements;
    EXPECT_NEAR(mse, residual.squaredNorm() / (p * n), 1e-12);
    EXPECT_NEAR(cost - mse,
                lambda * Eigen::Map<const Eigen::VectorXd>(x.data() + mlp.num_parameters(), d * p)
                             .squaredNorm() / p,
                1e-12);
    EXPECT_NEAR(max_distance,
                std::sqrt(Eigen::Map<const Eigen::Matrix3Xd>(residual.data(), 3, n * p)
                              .colwise()
                              .squaredNorm()
                              .maxCoeff()),
                1e-12);
  }
}

class TrainedAutoencoderTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    surfaces_ = new std::vector<Eigen::Matrix3Xd>(TrainingSurfaces());
    neutral_ = new Eigen::Matrix3Xd(BentGrid(0.6, 0.0));
    autoencoder_ = new SurfaceAutoencoder;
    SurfaceAutoencoderOptions options;
    options.latent_dim = 2;
    options.hidden_dims = {32, 32};
    options.activation = Activation::kTanh;
    options.output_scale = 0.5;
    options.latent_regularization = 1e-6;
    options.max_iterations = 3000;
    options.seed = 5;
    std::ostringstream log;
    std::string error;
    ASSERT_TRUE(autoencoder_->Train(*neutral_, *surfaces_, options, log, &error)) << error;
  }
  static void TearDownTestSuite() {
    delete autoencoder_;
    delete neutral_;
    delete surfaces_;
  }

  static std::vector<Eigen::Matrix3Xd>* surfaces_;
  static Eigen::Matrix3Xd* neutral_;
  static SurfaceAutoencoder* autoencoder_;
};

std::vector<Eigen::Matrix3Xd>* TrainedAutoencoderTest::surfaces_ = nullptr;
Eigen::Matrix3Xd* TrainedAutoencoderTest::neutral_ = nullptr;
SurfaceAutoencoder* TrainedAutoencoderTest::autoencoder_ = nullptr;

// The training surfaces (displacements up to ~0.6) are reproduced from their latents.
TEST_F(TrainedAutoencoderTest, ReproducesTrainingSurfaces) {
  const SurfaceAutoencoder& ae = *autoencoder_;
  ASSERT_TRUE(ae.trained());
  EXPECT_EQ(ae.latent_dim(), 2);
  EXPECT_EQ(ae.num_vertices(), 24);
  ASSERT_EQ(ae.training_latents().rows(), 2);
  ASSERT_EQ(ae.training_latents().cols(), 16);
  const SurfaceAutoencoderReport& report = ae.report();
  EXPECT_LT(report.final_loss, report.initial_loss);
  EXPECT_LT(report.rms_error, 2e-3) << report.termination;
  double worst = 0, mse = 0;
  for (int p = 0; p < 16; ++p) {
    const Eigen::Matrix3Xd decoded = ae.Decode(ae.training_latents().col(p));
    const double rms = RmsDistance(decoded, (*surfaces_)[p]);
    worst = std::max(worst, rms);
    mse += rms * rms / 16;
    worst = std::max(worst, (decoded - (*surfaces_)[p]).colwise().norm().maxCoeff());
  }
  EXPECT_LT(worst, 1e-2);
  EXPECT_NEAR(std::sqrt(mse), report.rms_error, 1e-9);
  std::printf("  training rms %.3e, max %.3e, %d iterations (%s)\n", report.rms_error,
              report.max_error, report.iterations, report.termination.c_str());
}

// FitLatent's data Jacobian against central differences of its residuals.
TEST_F(TrainedAutoencoderTest, FitCostJacobianMatchesCentralDifferences) {
  const SurfaceAutoencoder& ae = *autoencoder_;
  const std::vector<int> vertices = {3, 0, 17, 9, 23};
  Eigen::Matrix3Xd positions(3, vertices.size());
  for (size_t i = 0; i < vertices.size(); ++i) {
    positions.col(i) = (*surfaces_)[5].col(vertices[i]) + Eigen::Vector3d(0.01, -0.02, 0.03) * i;
  }
  const std::unique_ptr<ceres::CostFunction> cost = ae.NewFitCostFunction(vertices, positions);
  ASSERT_EQ(cost->num_residuals(), 15);
  ASSERT_EQ(cost->parameter_block_sizes(), std::vector<int32_t>{2});
  auto residuals = [&](const Eigen::VectorXd& z) {
    Eigen::VectorXd r(cost->num_residuals());
    const double* block = z.data();
    EXPECT_TRUE(cost->Evaluate(&block, r.data(), nullptr));
    return r;
  };
  for (const Eigen::VectorXd& z : {Eigen::VectorXd(ae.training_latents().col(2)),
                                   Eigen::VectorXd(Eigen::Vector2d(0.7, -1.3))}) {
    Eigen::VectorXd r(cost->num_residuals());
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jacobian(
        cost->num_residuals(), 2);
    const double* block = z.data();
    double* jacobian_blocks[1] = {jacobian.data()};
    ASSERT_TRUE(cost->Evaluate(&block, r.data(), jacobian_blocks));
    EXPECT_LT(testing::RelativeError(r, residuals(z)), 1e-14);
    // The residuals are sqrt(1/K) (surface_v(z) - y).
    const Eigen::Matrix3Xd decoded = ae.Decode(z);
    for (size_t i = 0; i < vertices.size(); ++i) {
      const Eigen::Vector3d expected =
          std::sqrt(1.0 / vertices.size()) * (decoded.col(vertices[i]) - positions.col(i));
      EXPECT_LT((r.segment<3>(3 * i) - expected).norm(), 1e-14);
    }
    const Eigen::MatrixXd numeric = testing::CentralDifferenceJacobian(residuals, z, 1e-4);
    EXPECT_LT(testing::RelativeError(jacobian, numeric), 1e-8);
  }
}

// A training surface is recovered from its vertices (all, or a third of them) starting
// from another surface's latent and from the mean latent, without a prior.
TEST_F(TrainedAutoencoderTest, FitLatentRecoversTrainingSurface) {
  const SurfaceAutoencoder& ae = *autoencoder_;
  LatentFitOptions no_prior;
  no_prior.latent_prior = 0.0;
  const int target = 13;
  const Eigen::Matrix3Xd& surface = (*surfaces_)[target];
  std::vector<int> all, third;
  for (int v = 0; v < ae.num_vertices(); ++v) {
    all.push_back(v);
    if (v % 3 == 0) third.push_back(v);
  }
  for (const std::vector<int>* vertices : {&all, &third}) {
    Eigen::Matrix3Xd positions(3, vertices->size());
    for (size_t i = 0; i < vertices->size(); ++i) positions.col(i) = surface.col((*vertices)[i]);
    for (const Eigen::VectorXd& start :
         {Eigen::VectorXd(ae.training_latents().col(2)), ae.MeanLatent()}) {
      Eigen::VectorXd z;
      double rms = -1;
      ASSERT_TRUE(ae.FitLatent(*vertices, positions, start, no_prior, &z, &rms));
      ASSERT_EQ(z.size(), 2);
      EXPECT_LT(rms, 5e-3);
      EXPECT_LT(RmsDistance(ae.Decode(z), surface), 5e-3);
      EXPECT_LT((z - ae.training_latents().col(target)).norm(),
                0.05 * ae.training_latents().col(target).norm() + 0.02);
    }
  }
}

// The prior of fits is learned from the trained latents as the physics model's is
// (LearnFitPrior's latent part): no training surface is the neutral, so it is centred on
// the mean latent, with the latents' second moment about it and the latent floor (0.01
// of the mean variance) as its covariance.
TEST_F(TrainedAutoencoderTest, FitPriorIsLearnedFromTheTrainingLatents) {
  const SurfaceAutoencoder& ae = *autoencoder_;
  const Eigen::MatrixXd& latents = ae.training_latents();
  const Eigen::VectorXd mean = latents.rowwise().mean();
  const Eigen::MatrixXd centred = latents.colwise() - mean;
  Eigen::MatrixXd covariance = centred * centred.transpose() / 16.0;
  covariance.diagonal().array() += FitPriorOptions().latent_floor * covariance.trace() / 2.0;
  const GaussianPrior& prior = ae.latent_prior();
  ASSERT_EQ(prior.size(), 2);
  EXPECT_LT(testing::RelativeError(prior.mean, mean), 1e-14);
  EXPECT_LT(testing::RelativeError(prior.covariance, covariance), 1e-14);
  // The whitening W: W^T W is the inverse covariance.
  EXPECT_LT(testing::RelativeError(prior.whitening.transpose() * prior.whitening,
                                   covariance.inverse()),
            1e-12);
}

// FitLatent minimizes the data term plus FitPriorTerm, the physics fits' latent prior
// rule: at its solution the data's gradient J^T r balances the prior's,
//   J^T r + (latent_prior / min(K, prior_points_cap)) C^-1 (z - mean)
//         + latent_regularization z = 0,
// and with latent_prior 0 (and no legacy term) the data's gradient vanishes: the
// unregularized fit. FitPriorTerm is that prior's value.
TEST_F(TrainedAutoencoderTest, FitLatentUsesThePhysicsFitsPriorRule) {
  const SurfaceAutoencoder& ae = *autoencoder_;
  const Eigen::Matrix3Xd target = BentGrid(1.7, 0.35);  // beyond the training surfaces
  std::vector<int> all;
  for (int v = 0; v < ae.num_vertices(); ++v) all.push_back(v);
  const int k = static_cast<int>(all.size());
  const GaussianPrior& prior = ae.latent_prior();
  const Eigen::MatrixXd precision = prior.covariance.inverse();
  const std::unique_ptr<ceres::CostFunction> data = ae.NewFitCostFunction(all, target);
  // J^T r of the data residuals at z.
  auto data_gradient = [&](const Eigen::VectorXd& z) {
    Eigen::VectorXd r(data->num_residuals());
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jacobian(
        data->num_residuals(), 2);
    const double* block = z.data();
    double* jacobian_blocks[1] = {jacobian.data()};
    EXPECT_TRUE(data->Evaluate(&block, r.data(), jacobian_blocks));
    return Eigen::VectorXd(jacobian.transpose() * r);
  };
  struct Case {
    double latent_prior, prior_points_cap, latent_regularization;
  };
  Eigen::VectorXd unregularized;
  for (const Case& c : {Case{0.0, 200.0, 0.0}, Case{0.03, 200.0, 0.0}, Case{0.03, 10.0, 0.0},
                        Case{0.03, 0.0, 1e-3}}) {
    LatentFitOptions fit;
    fit.latent_prior = c.latent_prior;
    fit.prior_points_cap = c.prior_points_cap;
    fit.latent_regularization = c.latent_regularization;
    Eigen::VectorXd z;
    double rms = -1;
    ASSERT_TRUE(ae.FitLatent(all, target, ae.MeanLatent(), fit, &z, &rms));
    const double points = c.prior_points_cap > 0 ? std::min<double>(k, c.prior_points_cap) : k;
    const double weight = c.latent_prior / points;
    const Eigen::VectorXd prior_gradient =
        weight * precision * (z - prior.mean) + c.latent_regularization * z;
    const Eigen::VectorXd gradient = data_gradient(z);
    EXPECT_LT((gradient + prior_gradient).norm(), 1e-4 * prior_gradient.norm() + 1e-9)
        << c.latent_prior << " " << c.prior_points_cap;
    EXPECT_NEAR(ae.FitPriorTerm(z, k, fit),
                weight * (z - prior.mean).dot(precision * (z - prior.mean)) +
                    c.latent_regularization * z.squaredNorm(),
                1e-12);
    if (c.latent_prior == 0.0) {
      EXPECT_LT(gradient.norm(), 1e-8) << "the unregularized fit: the data term alone";
      EXPECT_EQ(ae.FitPriorTerm(z, k, fit), 0.0);
      unregularized = z;
    } else {
      // The prior pulls the latent towards its centre, against the data.
      EXPECT_GT(gradient.norm(), 1e-3);
      EXPECT_LT(prior.SquaredMahalanobis(z), prior.SquaredMahalanobis(unregularized));
    }
  }
}

// With a linear skip, the fit cost keeps the skip weights' rows of the listed vertices:
// its residuals are the decoded surface's, and its Jacobian matches central differences.
// Before any iteration (max_iterations 0) the network decodes every training latent
// near the neutral plus the training surfaces' mean displacement (its output bias starts
// there, divided by output_scale; the small output layer adds a little): it learns only
// the variation about the mean. Without the division it started 1/s - 1 = 9 mean
// displacements off, and only tests that follow its exact optimisation path noticed.
TEST(SurfaceAutoencoderTest, StartsAtTheMeanDisplacement) {
  const std::vector<Eigen::Matrix3Xd> surfaces = TrainingSurfaces();
  const Eigen::Matrix3Xd neutral = BentGrid(0.6, 0.0);
  Eigen::Matrix3Xd mean = Eigen::Matrix3Xd::Zero(3, neutral.cols());
  for (const Eigen::Matrix3Xd& s : surfaces) mean += (s - neutral) / surfaces.size();
  double spread = 0.0;  // mean squared distance of the surfaces from their mean
  for (const Eigen::Matrix3Xd& s : surfaces) {
    spread += (s - neutral - mean).colwise().squaredNorm().mean() / surfaces.size();
  }
  SurfaceAutoencoderOptions options;
  options.latent_dim = 2;
  options.hidden_dims = {16};
  options.output_scale = 0.1;
  options.max_iterations = 0;
  SurfaceAutoencoder ae;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(ae.Train(neutral, surfaces, options, log, &error)) << error;
  ASSERT_EQ(ae.training_latents().cols(), static_cast<Eigen::Index>(surfaces.size()));
  const double mean_norm = mean.colwise().squaredNorm().mean();
  ASSERT_GT(mean_norm, 0.1 * spread) << "the mean displacement is not negligible";
  for (int p = 0; p < ae.training_latents().cols(); ++p) {
    const Eigen::Matrix3Xd decoded = ae.Decode(ae.training_latents().col(p));
    // Measured at most 0.39 of it (the output layer's start); 81 times it without the
    // division by output_scale.
    EXPECT_LT((decoded - neutral - mean).colwise().squaredNorm().mean(), mean_norm)
        << "surface " << p;
  }
}

TEST(SurfaceAutoencoderTest, LinearSkipFitCostMatchesTheDecoder) {
  const std::vector<Eigen::Matrix3Xd> surfaces = TrainingSurfaces();
  const Eigen::Matrix3Xd neutral = BentGrid(0.6, 0.0);
  SurfaceAutoencoderOptions options;
  options.latent_dim = 2;
  options.hidden_dims = {8};
  options.output_scale = 0.5;
  options.anchored = true;
  options.linear_skip = true;
  options.max_iterations = 200;
  SurfaceAutoencoder ae;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(ae.Train(neutral, surfaces, options, log, &error)) << error;
  EXPECT_LT(ae.report().final_loss, ae.report().initial_loss);
  // Zero decodes to the neutral; a non-zero latent moves the surface.
  EXPECT_LT((ae.Decode(Eigen::Vector2d::Zero()) - neutral).norm(), 1e-12);
  const std::vector<int> vertices = {3, 0, 17, 9, 23};
  const Eigen::Matrix3Xd positions = surfaces[4](Eigen::all, vertices);
  const std::unique_ptr<ceres::CostFunction> cost = ae.NewFitCostFunction(vertices, positions);
  auto residuals = [&](const Eigen::VectorXd& z) {
    Eigen::VectorXd r(cost->num_residuals());
    const double* block = z.data();
    EXPECT_TRUE(cost->Evaluate(&block, r.data(), nullptr));
    return r;
  };
  const Eigen::Vector2d z(0.4, -0.9);
  const Eigen::Matrix3Xd decoded = ae.Decode(z);
  const Eigen::VectorXd r = residuals(z);
  for (size_t i = 0; i < vertices.size(); ++i) {
    const Eigen::Vector3d expected =
        std::sqrt(1.0 / vertices.size()) * (decoded.col(vertices[i]) - positions.col(i));
    EXPECT_LT((r.segment<3>(3 * i) - expected).norm(), 1e-14);
  }
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> jacobian(
      cost->num_residuals(), 2);
  Eigen::VectorXd unused(cost->num_residuals());
  const double* block = z.data();
  double* jacobian_blocks[1] = {jacobian.data()};
  ASSERT_TRUE(cost->Evaluate(&block, unused.data(), jacobian_blocks));
  const Eigen::MatrixXd numeric = testing::CentralDifferenceJacobian(residuals, z, 1e-4);
  EXPECT_LT(testing::RelativeError(jacobian, numeric), 1e-8);
  EXPECT_GT(numeric.norm(), 1e-3);
}

// Training with checkpoints: a second run with a larger budget resumes at the first's
// last point (its loss) and counts its iterations; other options start anew.
TEST(SurfaceAutoencoderTest, TrainingResumesFromItsCheckpoint) {
  testing::TempDir dir;
  const std::vector<Eigen::Matrix3Xd> surfaces = TrainingSurfaces();
  const Eigen::Matrix3Xd neutral = BentGrid(0.6, 0.0);
  SurfaceAutoencoderOptions options;
  options.latent_dim = 2;
  options.hidden_dims = {8};
  options.output_scale = 0.5;
  options.max_iterations = 10;
  options.checkpoint_directory = dir.File("checkpoint");
  options.checkpoint_seconds = 0.0;
  std::ostringstream log;
  std::string error;
  SurfaceAutoencoder first;
  ASSERT_TRUE(first.Train(neutral, surfaces, options, log, &error)) << error;
  EXPECT_EQ(first.report().iterations, 10);
  options.max_iterations = 15;
  SurfaceAutoencoder resumed;
  ASSERT_TRUE(resumed.Train(neutral, surfaces, options, log, &error)) << error;
  EXPECT_NE(log.str().find("resuming after iteration 10"), std::string::npos) << log.str();
  EXPECT_EQ(resumed.report().iterations, 15);
  EXPECT_EQ(resumed.report().iterations_before, 10);
  // Its loss at the checkpoint; its initial loss the training's (it was the checkpoint's,
  // and the report read as a training that had barely moved).
  EXPECT_NEAR(resumed.report().resumed_loss, first.report().final_loss,
              1e-12 * first.report().final_loss);
  EXPECT_EQ(resumed.report().initial_loss, first.report().initial_loss);
  EXPECT_EQ(first.report().resumed_loss, 0.0);
  EXPECT_LT(resumed.report().final_loss, first.report().final_loss);
  // The budget used up: no iteration, the same decoder.
  SurfaceAutoencoder same;
  ASSERT_TRUE(same.Train(neutral, surfaces, options, log, &error)) << error;
  EXPECT_EQ(same.report().iterations, 15);
  EXPECT_EQ(same.Decode(Eigen::Vector2d(0.3, -0.2)), resumed.Decode(Eigen::Vector2d(0.3, -0.2)));
  // Another seed: anew, and the log says why.
  options.seed = 7;
  std::ostringstream other_log;
  SurfaceAutoencoder other;
  ASSERT_TRUE(other.Train(neutral, surfaces, options, other_log, &error)) << error;
  EXPECT_NE(other_log.str().find("not resuming the checkpoint in " + options.checkpoint_directory +
                                 ": 'options' differs"),
            std::string::npos)
      << other_log.str();
  EXPECT_EQ(other.report().iterations, 15);
}

// A small auto-encoder of the bent grids (8 hidden units), quick to train.
SurfaceAutoencoderOptions SmallOptions() {
  SurfaceAutoencoderOptions options;
  options.latent_dim = 2;
  options.hidden_dims = {8};
  options.output_scale = 0.5;
  return options;
}

// A checkpoint whose numbers are finite but not the point it recorded is refused, naming
// it (resumed, every run failed with "training diverged").
TEST(SurfaceAutoencoderTest, ACheckpointWhoseNumbersGiveAnotherLossIsRefused) {
  testing::TempDir dir;
  const std::vector<Eigen::Matrix3Xd> surfaces = TrainingSurfaces();
  const Eigen::Matrix3Xd neutral = BentGrid(0.6, 0.0);
  SurfaceAutoencoderOptions options = SmallOptions();
  options.max_iterations = 5;
  options.checkpoint_directory = dir.File("checkpoint");
  options.checkpoint_seconds = 0.0;
  std::ostringstream log;
  std::string error;
  SurfaceAutoencoder first;
  ASSERT_TRUE(first.Train(neutral, surfaces, options, log, &error)) << error;
  testing::ScaleCheckpointParameters(options.checkpoint_directory, 1.5);
  options.max_iterations = 10;
  SurfaceAutoencoder resumed;
  EXPECT_FALSE(resumed.Train(neutral, surfaces, options, log, &error));
  EXPECT_EQ(error.rfind("the checkpoint in " + options.checkpoint_directory +
                            " resumed gives a loss of ",
                        0),
            0u)
      << error;
  EXPECT_NE(error.find(": it is damaged; remove it to train anew"), std::string::npos) << error;
}

// How often `text` occurs in `log`.
int Count(const std::string& log, const std::string& text) {
  int count = 0;
  for (size_t at = log.find(text); at != std::string::npos; at = log.find(text, at + 1)) ++count;
  return count;
}

// A function tolerance that ends each L-BFGS solve after a few iterations (Ceres'
// CONVERGENCE, as on a loss at its round-off): without restarts training stops there,
// with them it restarts from the accepted point, as end-to-end training does, and spends
// its whole budget. The progress lines number the iterations on across restarts, each
// once; a run with checkpoints ends at the same point, and a resumed run goes on.
TEST(SurfaceAutoencoderTest, TrainingRestartsWhereLbfgsStallsAndUsesItsBudget) {
  const std::vector<Eigen::Matrix3Xd> surfaces = TrainingSurfaces();
  const Eigen::Matrix3Xd neutral = BentGrid(0.6, 0.0);
  SurfaceAutoencoderOptions options = SmallOptions();
  options.function_tolerance = 0.02;
  options.max_iterations = 40;
  options.log_every = 1;
  std::string error;
  options.max_restarts = 0;
  std::ostringstream stopped_log;
  SurfaceAutoencoder stopped;
  ASSERT_TRUE(stopped.Train(neutral, surfaces, options, stopped_log, &error)) << error;
  const int stall = stopped.report().iterations;
  EXPECT_LT(stall, 40) << stopped.report().termination;
  EXPECT_NE(stopped.report().termination.find("Function tolerance"), std::string::npos)
      << stopped.report().termination;
  EXPECT_EQ(stopped.report().restarts, 0);

  options.max_restarts = 50;
  std::ostringstream log;
  SurfaceAutoencoder restarted;
  ASSERT_TRUE(restarted.Train(neutral, surfaces, options, log, &error)) << error;
  const SurfaceAutoencoderReport& report = restarted.report();
  EXPECT_EQ(report.iterations, 40) << log.str();
  EXPECT_GE(report.restarts, 1);
  EXPECT_LE(report.restarts, 50);
  EXPECT_LT(report.final_loss, stopped.report().final_loss);
  EXPECT_EQ(Count(log.str(), "  L-BFGS stopped (Function tolerance reached"), report.restarts)
      << log.str();
  // The first restart is where the run without restarts stopped.
  EXPECT_NE(log.str().find("; restarting from iteration " + std::to_string(stall) + "\n"),
            std::string::npos)
      << log.str();
  for (int i = 0; i <= 40; ++i) {
    char line[64];
    std::snprintf(line, sizeof(line), "surface autoencoder iter %5d/40 ", i);
    EXPECT_EQ(Count(log.str(), line), 1) << line;
  }
  EXPECT_NE(log.str().find("40 iterations (" + std::to_string(report.restarts) + " L-BFGS rest"),
            std::string::npos)
      << log.str();

  // With checkpoints (written at every iteration across the restarts): the same point.
  testing::TempDir dir;
  options.checkpoint_directory = dir.File("checkpoint");
  options.checkpoint_seconds = 0.0;
  options.log_every = 0;
  std::ostringstream checkpoint_log;
  SurfaceAutoencoder checkpointed;
  ASSERT_TRUE(checkpointed.Train(neutral, surfaces, options, checkpoint_log, &error)) << error;
  EXPECT_EQ(checkpointed.report().iterations, 40);
  EXPECT_EQ(checkpointed.report().restarts, report.restarts);
  EXPECT_EQ(checkpointed.parameters(), restarted.parameters());
  EXPECT_EQ(checkpointed.training_latents(), restarted.training_latents());
  SolverCheckpoint saved;
  std::string why_not;
  ASSERT_TRUE(ReadSolverCheckpoint(options.checkpoint_directory,
                                   AutoencoderCheckpointKey(options, neutral, surfaces),
                                   static_cast<int>(restarted.parameters().size() + 2 * 16),
                                   &saved, &why_not))
      << why_not;
  EXPECT_EQ(saved.iterations, 40);
  EXPECT_EQ(saved.loss, report.final_loss);

  // Half the budget, then resumed with the whole of it: the iterations count on.
  options.checkpoint_directory = dir.File("halves");
  options.max_iterations = 20;
  SurfaceAutoencoder half;
  ASSERT_TRUE(half.Train(neutral, surfaces, options, checkpoint_log, &error)) << error;
  EXPECT_EQ(half.report().iterations, 20);
  options.max_iterations = 40;
  SurfaceAutoencoder resumed;
  ASSERT_TRUE(resumed.Train(neutral, surfaces, options, checkpoint_log, &error)) << error;
  EXPECT_EQ(resumed.report().iterations_before, 20);
  EXPECT_EQ(resumed.report().iterations, 40);
  EXPECT_LT(resumed.report().final_loss, half.report().final_loss);
}

// util/fault_injection.h: every evaluation of the training objective from the 30th on
// fails, as a non-finite loss does.
int g_evaluations = 0;
bool FailFromThe30thEvaluation(const char* point) {
  return std::string(point) == "autoencoder:evaluate" && ++g_evaluations >= 30;
}

// A line search that finds no valid step (Ceres' FAILURE) is restarted from the accepted
// point (here its restart cannot evaluate its start either, which ends training). Without
// a checkpoint folder the result is the point L-BFGS accepted last, which Ceres does not
// copy back after a FAILURE: the same weights and latents as a run that stops there, not
// the random start.
TEST(SurfaceAutoencoderTest, AFailedLineSearchKeepsTheAcceptedPoint) {
  const std::vector<Eigen::Matrix3Xd> surfaces = TrainingSurfaces();
  const Eigen::Matrix3Xd neutral = BentGrid(0.6, 0.0);
  SurfaceAutoencoderOptions options = SmallOptions();
  options.max_iterations = 200;
  std::ostringstream log;
  std::string error;
  SurfaceAutoencoder failed;
  g_evaluations = 0;
  const FailureHook previous = SetFailureHookForTesting(&FailFromThe30thEvaluation);
  const bool trained = failed.Train(neutral, surfaces, options, log, &error);
  SetFailureHookForTesting(previous);
  ASSERT_TRUE(trained) << error;
  const SurfaceAutoencoderReport& report = failed.report();
  const int accepted = report.iterations;
  ASSERT_GT(accepted, 0);
  EXPECT_LT(accepted, 30);
  EXPECT_EQ(report.restarts, 1);
  EXPECT_NE(log.str().find("  L-BFGS stopped (Numerical failure in line search"),
            std::string::npos)
      << log.str();
  EXPECT_NE(log.str().find("; restarting from iteration " + std::to_string(accepted) + "\n"),
            std::string::npos)
      << log.str();
  EXPECT_LT(report.final_loss, report.initial_loss);

  // The same training stopped by its budget at that iteration.
  options.max_iterations = accepted;
  SurfaceAutoencoder stopped;
  ASSERT_TRUE(stopped.Train(neutral, surfaces, options, log, &error)) << error;
  EXPECT_EQ(failed.parameters(), stopped.parameters());
  EXPECT_EQ(failed.training_latents(), stopped.training_latents());
  EXPECT_EQ(report.final_loss, stopped.report().final_loss);
  // Not the start.
  options.max_iterations = 0;
  SurfaceAutoencoder start;
  ASSERT_TRUE(start.Train(neutral, surfaces, options, log, &error)) << error;
  EXPECT_EQ(start.report().iterations, 0);
  EXPECT_GT((failed.parameters() - start.parameters()).norm(), 1e-3);
}

// A training surface that is the neutral centres the prior of fits (as the physics
// model's on its neutral training pose): its mean is that surface's latent.
TEST(SurfaceAutoencoderTest, FitPriorIsCentredOnTheNeutralsLatent) {
  std::vector<Eigen::Matrix3Xd> surfaces = TrainingSurfaces();
  const Eigen::Matrix3Xd neutral = BentGrid(0.6, 0.0);
  surfaces.insert(surfaces.begin() + 3, neutral);
  SurfaceAutoencoderOptions options = SmallOptions();
  options.max_iterations = 30;
  SurfaceAutoencoder ae;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(ae.Train(neutral, surfaces, options, log, &error)) << error;
  const Eigen::MatrixXd& latents = ae.training_latents();
  const Eigen::VectorXd centre = latents.col(3);
  EXPECT_EQ(ae.latent_prior().mean, centre);
  const Eigen::MatrixXd about = latents.colwise() - centre;
  Eigen::MatrixXd covariance = about * about.transpose() / 17.0;
  covariance.diagonal().array() += FitPriorOptions().latent_floor * covariance.trace() / 2.0;
  EXPECT_LT(testing::RelativeError(ae.latent_prior().covariance, covariance), 1e-14);
}

TEST(SurfaceAutoencoderTest, BadInputs) {
  SurfaceAutoencoder ae;
  std::ostringstream log;
  std::string error;
  const Eigen::Matrix3Xd neutral = BentGrid(0.5, 0.0);
  SurfaceAutoencoderOptions options;
  options.max_iterations = 2;
  EXPECT_FALSE(ae.Train(neutral, {}, options, log, &error));
  EXPECT_NE(error.find("no training surfaces"), std::string::npos) << error;
  EXPECT_FALSE(ae.Train(neutral, {BentGrid(0.3, 0.1), Eigen::Matrix3Xd::Zero(3, 5)}, options, log,
                        &error));
  EXPECT_NE(error.find("training surface 1 has 5 vertices"), std::string::npos) << error;
  Eigen::Matrix3Xd bad = BentGrid(0.3, 0.1);
  bad(1, 4) = std::nan("");
  EXPECT_FALSE(ae.Train(neutral, {bad}, options, log, &error));
  EXPECT_NE(error.find("non-finite"), std::string::npos) << error;
  options.latent_dim = 0;
  EXPECT_FALSE(ae.Train(neutral, {bad}, options, log, &error));
  EXPECT_NE(error.find("latent_dim"), std::string::npos) << error;
  options = SurfaceAutoencoderOptions();
  options.max_restarts = -1;
  EXPECT_FALSE(ae.Train(neutral, {BentGrid(0.3, 0.1)}, options, log, &error));
  EXPECT_NE(error.find("max_restarts must be >= 0"), std::string::npos) << error;
  options = SurfaceAutoencoderOptions();
  options.function_tolerance = 1.0;
  EXPECT_FALSE(ae.Train(neutral, {BentGrid(0.3, 0.1)}, options, log, &error));
  EXPECT_NE(error.find("function_tolerance must be in [0, 1)"), std::string::npos) << error;
  EXPECT_FALSE(ae.trained());
}

}  // namespace
}  // namespace aqs
