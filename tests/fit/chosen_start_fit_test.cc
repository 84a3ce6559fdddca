#include "fit/chosen_start_fit.h"

#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "testing/fit_fixtures.h"

namespace aqs {
namespace {

RigidTransform Rotated(double angle, const Eigen::Vector3d& axis, const Eigen::Vector3d& shift) {
  RigidTransform t;
  t.rotation = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
  t.translation = shift;
  return t;
}

TEST(BonesBeyondTrainingPosesTest, ComparesWithTheWidestTrainingMotion) {
  FitPrior prior;
  GaussianPrior bone;
  bone.mean = Eigen::VectorXd::Zero(6);
  // Standard deviations 0.1 (rad, length): the training motions below are 2 and 1 of them.
  ASSERT_TRUE(bone.SetCovariance(0.01 * Eigen::MatrixXd::Identity(6, 6)));
  prior.bones = {bone, bone};
  // Training motions of bone 0: rest, 0.2 rad about x, 0.1 along y; bone 1 has none.
  std::vector<Bone> bones(2);
  bones[0].pose_transforms = {RigidTransform(), Rotated(0.2, Eigen::Vector3d::UnitX(), {0, 0, 0}),
                              Rotated(0.0, Eigen::Vector3d::UnitX(), {0, 0.1, 0})};
  const RigidTransform far = Rotated(1.0, Eigen::Vector3d::UnitZ(), {1, 2, 3});
  // A training pose's motion, a smaller one in another direction: within.
  EXPECT_FALSE(BonesBeyondTrainingPoses(prior, bones, {bones[0].pose_transforms[1], far}));
  EXPECT_FALSE(BonesBeyondTrainingPoses(
      prior, bones, {Rotated(0.15, Eigen::Vector3d::UnitY(), {0, 0, 0}), RigidTransform()}));
  // Farther than the widest (0.2 rad): beyond.
  EXPECT_TRUE(BonesBeyondTrainingPoses(
      prior, bones, {Rotated(0.25, Eigen::Vector3d::UnitX(), {0, 0, 0}), RigidTransform()}));
  EXPECT_TRUE(BonesBeyondTrainingPoses(
      prior, bones, {Rotated(0.0, Eigen::Vector3d::UnitX(), {0.2, 0.1, 0.1}), RigidTransform()}));
  // Within one standard deviation is never beyond, however narrow the training motions.
  bones[0].pose_transforms = {RigidTransform()};
  EXPECT_FALSE(BonesBeyondTrainingPoses(
      prior, bones, {Rotated(0.09, Eigen::Vector3d::UnitZ(), {0, 0, 0}), RigidTransform()}));
  EXPECT_TRUE(BonesBeyondTrainingPoses(
      prior, bones, {Rotated(0.11, Eigen::Vector3d::UnitZ(), {0, 0, 0}), RigidTransform()}));
}

// The fit's objective at a result (its bones set on the fitter).
double ObjectiveAt(LatentFitter* fitter, const FitTarget& target, const LatentFitResult& fit) {
  fitter->set_bone_transforms(fit.bones);
  return fitter->Objective(target, fit.surface, fit.latent);
}

class ChosenStartFitTest : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = testing::PretrainedBarForFits(true);
    ASSERT_TRUE(testing::StoreTrainingEquilibria(&model_));
    options_.solver.relative_force_tolerance = 1e-10;
  }

  // A target made by latent z with the bone moved by `bone` (the training poses' bone
  // never moves).
  FitTarget Target(const Eigen::VectorXd& z, const RigidTransform& bone) {
    LatentFitter simulator(model_, options_);
    simulator.set_bone_transforms({bone});
    Eigen::Matrix3Xd state, surface;
    std::string error;
    EXPECT_TRUE(simulator.Simulate(z, &state, &surface, &error)) << error;
    return FullSurfaceTarget(surface);
  }

  ActiveModel model_;
  LatentFitOptions options_;
};

// A fit from a training pose that moves the bone beyond the training poses' motions
// runs again from the given start; the fit kept has the smaller objective of the two
// (each also run on its own), and the counters sum both.
TEST_F(ChosenStartFitTest, RetriesFromTheGivenStartAndKeepsTheSmallerObjective) {
  const Eigen::VectorXd z = 0.8 * model_.latents.col(2) - 0.3 * model_.latents.col(5);
  const FitTarget target =
      Target(z, Rotated(0.15, Eigen::Vector3d(1.0, 0.3, -0.2), {0.03, -0.05, 0.02}));
  std::string error;
  // Each start on its own.
  LatentFitResult chosen_alone, given_alone;
  std::string chosen_name;
  double chosen_objective = 0, given_objective = 0;
  {
    LatentFitter fitter(model_, options_);
    Eigen::VectorXd start = fitter.PriorLatent();
    ASSERT_TRUE(fitter.ChooseStart(&target, nullptr, PointCloudFitOptions(), FitStartOptions(),
                                   &start, &chosen_name, &error)) << error;
    ASSERT_NE(chosen_name, "given") << "the test needs a start at a training pose";
    ASSERT_TRUE(fitter.Fit(target, start, &chosen_alone, &error)) << error;
    chosen_objective = ObjectiveAt(&fitter, target, chosen_alone);
    ASSERT_TRUE(BonesBeyondTrainingPoses(fitter.prior(), model_.bones, chosen_alone.bones));
  }
  {
    LatentFitter fitter(model_, options_);
    ASSERT_TRUE(fitter.Fit(target, fitter.PriorLatent(), &given_alone, &error)) << error;
    given_objective = ObjectiveAt(&fitter, target, given_alone);
  }
  LatentFitter fitter(model_, options_);
  LatentFitResult fit;
  ASSERT_TRUE(FitFromChosenStart(&fitter, &target, nullptr, PointCloudFitOptions(),
                                 FitStartOptions(), fitter.PriorLatent(), &fit, &error)) << error;
  EXPECT_NE(fit.retry_reason.find("beyond"), std::string::npos) << fit.retry_reason;
  const bool given_better = given_objective < chosen_objective;
  EXPECT_EQ(fit.retry_kept, given_better);
  EXPECT_EQ(fit.start, given_better ? "given" : chosen_name);
  const double kept = ObjectiveAt(&fitter, target, fit);
  EXPECT_NEAR(kept, std::min(chosen_objective, given_objective),
              1e-6 * std::max(chosen_objective, given_objective));
  EXPECT_EQ(fit.iterations, chosen_alone.iterations + given_alone.iterations);
  // The fitter is left at the kept fit.
  EXPECT_LT((fitter.start_state() - fit.state).cwiseAbs().maxCoeff(), 1e-12);

  // Without the retry: the fit from the chosen start alone.
  FitStartOptions no_retry;
  no_retry.retry_from_given = false;
  LatentFitter plain(model_, options_);
  LatentFitResult once;
  ASSERT_TRUE(FitFromChosenStart(&plain, &target, nullptr, PointCloudFitOptions(), no_retry,
                                 plain.PriorLatent(), &once, &error)) << error;
  EXPECT_TRUE(once.retry_reason.empty());
  EXPECT_EQ(once.start, chosen_name);
  EXPECT_EQ(once.iterations, chosen_alone.iterations);
}

// A fit that stops before converging runs again from the given start; one that ends at
// the training poses' bones and converges does not.
TEST_F(ChosenStartFitTest, RetriesWhenNotConvergedAndNotOtherwise) {
  const Eigen::VectorXd z = 0.8 * model_.latents.col(2) - 0.3 * model_.latents.col(5);
  const FitTarget target = Target(z, RigidTransform());
  std::string error;
  {
    LatentFitOptions one = options_;
    one.max_iterations = 1;
    one.function_tolerance = 1e-14;
    LatentFitter fitter(model_, one);
    LatentFitResult fit;
    ASSERT_TRUE(FitFromChosenStart(&fitter, &target, nullptr, PointCloudFitOptions(),
                                   FitStartOptions(), fitter.PriorLatent(), &fit, &error)) << error;
    ASSERT_NE(fit.start, "") << error;
    EXPECT_NE(fit.retry_reason.find("did not converge"), std::string::npos) << fit.retry_reason;
  }
  {
    // The target is a training pose's own equilibrium: it is the start, and the fit ends
    // there with the bone at rest.
    const int p = 4;
    LatentFitter fitter(model_, options_);
    const FitTarget own = Target(model_.latents.col(p), RigidTransform());
    LatentFitResult fit;
    ASSERT_TRUE(FitFromChosenStart(&fitter, &own, nullptr, PointCloudFitOptions(),
                                   FitStartOptions(), fitter.PriorLatent(), &fit, &error)) << error;
    EXPECT_EQ(fit.start, model_.poses[p].name);
    EXPECT_TRUE(fit.converged) << fit.message;
    EXPECT_TRUE(fit.retry_reason.empty()) << fit.retry_reason;
  }
}

// The given start's solve in the start choice counts in the fit's work (it was left
// out: the fit's counters start at its own first solve).
TEST_F(ChosenStartFitTest, TheStartChoicesSolveCountsInTheWork) {
  const FitTarget target = Target(0.5 * model_.latents.col(2), RigidTransform());
  FitStartOptions given_only;
  given_only.training_poses = false;
  given_only.retry_from_given = false;
  LatentFitter direct_fitter(model_, options_);
  LatentFitResult direct, chosen;
  std::string error;
  const Eigen::VectorXd start = direct_fitter.PriorLatent();
  ASSERT_TRUE(direct_fitter.Fit(target, start, &direct, &error)) << error;
  LatentFitter fitter(model_, options_);
  ASSERT_TRUE(FitFromChosenStart(&fitter, &target, nullptr, PointCloudFitOptions(), given_only,
                                 start, &chosen, &error))
      << error;
  EXPECT_EQ(chosen.start, "given");
  EXPECT_EQ(fitter.start_choice_work().solves, 1);
  EXPECT_GE(chosen.solves, direct.solves + 1);
  EXPECT_GE(chosen.solve_factorizations, fitter.start_choice_work().solve_factorizations);
}

}  // namespace
}  // namespace aqs
