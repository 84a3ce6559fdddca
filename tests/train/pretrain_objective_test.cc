#include "train/pretrain_objective.h"

#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "learn/grid_actuation_field.h"
#include "testing/finite_difference.h"
#include "testing/test_meshes.h"

namespace aqs {
namespace {

// A small decoder (latent 3, hidden {6, 5}, a 36-node grid on a 72-element bar), 4 random
// targets about the identity, random element weights, and a random point x =
// [params; latents].
class PretrainObjectiveTest : public ::testing::Test {
 protected:
  PretrainObjectiveTest() : mesh_(testing::BarMesh(3, 2, 2, 0.5)), rng_(7) {
    GridActuationFieldOptions field;
    field.node_spacing = 0.6;
    DecoderSpec spec;
    spec.latent_dim = 3;
    spec.hidden_dims = {6, 5};
    decoder_ = std::make_unique<ActuationDecoder>(spec, GridActuationField(mesh_, field));
    const int m = mesh_.num_tets();
    for (int p = 0; p < 4; ++p) targets_.push_back(testing::RandomActuation(m, 0.3, &rng_));
    std::uniform_real_distribution<double> uniform(0.2, 2.0);
    weights_.resize(m);
    for (int e = 0; e < m; ++e) weights_[e] = uniform(rng_);
  }

  Eigen::VectorXd RandomPoint(const PretrainObjective& objective, double stddev) {
    std::normal_distribution<double> normal(0.0, stddev);
    Eigen::VectorXd x(objective.NumParameters());
    for (int i = 0; i < x.size(); ++i) x[i] = normal(rng_);
    return x;
  }

  TetMesh mesh_;
  std::mt19937 rng_;
  std::unique_ptr<ActuationDecoder> decoder_;
  std::vector<ActuationMatrix> targets_;
  Eigen::VectorXd weights_;
};

// The analytic gradient against 4th-order central differences, with each regularizer off
// and on (weight decay alone too), at random points of two scales.
TEST_F(PretrainObjectiveTest, GradientMatchesCentralDifferences) {
  const double regularizers[][2] = {{0.0, 0.0}, {1e-2, 0.0}, {0.0, 1e-2}, {3e-3, 5e-2}};
  for (const auto& lambda : regularizers) {
    const PretrainObjective objective(*decoder_, targets_, weights_, lambda[0], lambda[1]);
    for (const double scale : {0.3, 1.0}) {
      const Eigen::VectorXd x = RandomPoint(objective, scale);
      Eigen::VectorXd gradient(x.size());
      objective.Loss(x.data(), gradient.data(), nullptr);
      const Eigen::VectorXd numeric = testing::CentralDifferenceGradient(
          [&](const Eigen::VectorXd& y) { return objective.Loss(y.data(), nullptr, nullptr); },
          x, 1e-4);
      EXPECT_LT(testing::RelativeError(gradient, numeric), 1e-7)
          << "latent regularization " << lambda[0] << ", decoder regularization " << lambda[1]
          << ", scale " << scale;
    }
  }
}

// The loss is the data term (reported through mse) plus lambda_z / P sum |z|^2 plus
// lambda_w |params|^2, and Evaluate gives the same.
TEST_F(PretrainObjectiveTest, LossIsTheDataTermPlusBothRegularizers) {
  const double lambda_z = 3e-3, lambda_w = 5e-2;
  const PretrainObjective plain(*decoder_, targets_, weights_, 0.0, 0.0);
  const PretrainObjective regularized(*decoder_, targets_, weights_, lambda_z, lambda_w);
  const Eigen::VectorXd x = RandomPoint(regularized, 0.5);
  const int np = decoder_->num_parameters();
  double mse = -1.0;
  const double data = plain.Loss(x.data(), nullptr, nullptr);
  const double loss = regularized.Loss(x.data(), nullptr, &mse);
  EXPECT_DOUBLE_EQ(mse, data);
  const double expected = data + lambda_z * x.tail(x.size() - np).squaredNorm() / 4.0 +
                          lambda_w * x.head(np).squaredNorm();
  EXPECT_NEAR(loss, expected, 1e-12 * expected);
  double cost = 0.0;
  ASSERT_TRUE(regularized.Evaluate(x.data(), &cost, nullptr));
  EXPECT_EQ(cost, loss);
}

// With the latents held, the gradient's latent entries are zero, its decoder entries and
// the loss are unchanged.
TEST_F(PretrainObjectiveTest, HeldLatentsHaveZeroGradient) {
  PretrainObjective objective(*decoder_, targets_, weights_, 3e-3, 5e-2);
  const Eigen::VectorXd x = RandomPoint(objective, 0.5);
  const int np = decoder_->num_parameters();
  Eigen::VectorXd free_gradient(x.size()), held_gradient(x.size());
  const double free_loss = objective.Loss(x.data(), free_gradient.data(), nullptr);
  objective.HoldLatents(true);
  const double held_loss = objective.Loss(x.data(), held_gradient.data(), nullptr);
  EXPECT_EQ(held_loss, free_loss);
  EXPECT_GT(free_gradient.tail(x.size() - np).norm(), 0.0);
  EXPECT_EQ(held_gradient.tail(x.size() - np).norm(), 0.0);
  EXPECT_EQ((held_gradient.head(np) - free_gradient.head(np)).norm(), 0.0);
}

}  // namespace
}  // namespace aqs
