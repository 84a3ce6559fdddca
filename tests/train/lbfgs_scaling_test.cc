// TrainOptions::lbfgs_scaling: L-BFGS' initial inverse Hessian gamma I, gamma = s^T y /
// y^T y of the last step, reaches Ceres' solver, and training still lowers the loss.

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "testing/training_fixtures.h"
#include "train/trainer.h"

namespace aqs {
namespace {

TrainReport Train(const ActiveModel& pretrained, bool scaling, int iterations) {
  TrainOptions options;
  options.lbfgs_scaling = scaling;
  options.max_iterations = iterations;
  options.max_restarts = 0;
  options.log_every = 0;
  ActiveModel model = pretrained;
  TrainReport report;
  std::ostringstream log;
  std::string error;
  EXPECT_TRUE(TrainEndToEnd(options, &model, &report, log, &error)) << error << log.str();
  return report;
}

TEST(LbfgsScalingTest, ChangesTheStepsFromTheSecondIterationOn) {
  // The synthetic bar with 4 poses, volumetric targets and a small pre-trained decoder.
  testing::SyntheticBarSpec spec;
  spec.node_spacing = 0.35;
  spec.pretrain_iterations = 40;
  const ActiveModel pretrained = testing::PretrainedSyntheticBar(spec);
  // The first iteration has no curvature pair yet: gamma = 1, the same step either way.
  const TrainReport first_scaled = Train(pretrained, true, 1);
  const TrainReport first_plain = Train(pretrained, false, 1);
  ASSERT_EQ(first_scaled.iterations, 1);
  EXPECT_EQ(first_scaled.final_loss, first_plain.final_loss);

  // Then the scale of the steps differs, and so does the trajectory; both descend.
  const TrainReport scaled = Train(pretrained, true, 8);
  const TrainReport plain = Train(pretrained, false, 8);
  std::printf("loss %.6e -> after 8 iterations: scaled %.6e (%d evaluations), plain %.6e (%d)\n",
              scaled.initial_loss, scaled.final_loss, scaled.iteration_cost.evaluations,
              plain.final_loss, plain.iteration_cost.evaluations);
  EXPECT_LT(scaled.final_loss, first_scaled.final_loss);
  EXPECT_LT(plain.final_loss, first_plain.final_loss);
  EXPECT_GT(std::abs(scaled.final_loss - plain.final_loss), 1e-6 * plain.final_loss);
}

}  // namespace
}  // namespace aqs
