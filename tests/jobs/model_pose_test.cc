// What a job simulates with a trained model (jobs/model_pose.h): a training pose by
// name, and the checks that refuse latents and bone motions no simulation should chase.

#include "jobs/model_pose.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/fit_fixtures.h"

namespace aqs {
namespace {

class ModelPoseTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { model_ = new ActiveModel(testing::PretrainedBarForFits(true)); }
  static void TearDownTestSuite() { delete model_; }
  static ActiveModel* model_;
};
ActiveModel* ModelPoseTest::model_ = nullptr;

TEST_F(ModelPoseTest, ATrainingPoseByNameIsItsLatentAndBoneMotions) {
  const ActiveModel& model = *model_;
  const int p = model.num_poses() - 1;
  ModelPose pose;
  std::string error;
  ASSERT_TRUE(ResolveModelPose(model, "", model.poses[p].name, &pose, &error)) << error;
  EXPECT_EQ(pose.training_pose, p);
  EXPECT_EQ(pose.latent, Eigen::VectorXd(model.latents.col(p)));
  ASSERT_EQ(pose.bones.size(), 1u);
  EXPECT_EQ(pose.bones[0].translation, model.bones[0].pose_transforms[p].translation);
  EXPECT_FALSE(ResolveModelPose(model, "", "no_such_pose", &pose, &error));
  EXPECT_EQ(error.rfind("the model has no training pose 'no_such_pose'; it has: " +
                            model.poses[0].name,
                        0),
            0u)
      << error;
}

TEST_F(ModelPoseTest, TrainingLatentsPassAndFarBonesAreRefused) {
  const ActiveModel& model = *model_;
  std::string error;
  for (int p = 0; p < model.num_poses(); ++p) {
    EXPECT_TRUE(CheckLatentActuations(model, model.latents.col(p), "z.txt", &error)) << error;
  }
  std::vector<RigidTransform> bones(1);
  EXPECT_TRUE(CheckBoneMotions(model, bones, "z.txt", &error)) << error;
  const Eigen::Matrix3Xd& neutral = model.neutral.vertices;
  const double size = (neutral.rowwise().maxCoeff() - neutral.rowwise().minCoeff()).norm();
  bones[0].translation = Eigen::Vector3d(0.9 * size, 0, 0);
  EXPECT_TRUE(CheckBoneMotions(model, bones, "z.txt", &error)) << error;
  bones[0].translation = Eigen::Vector3d(0, 0, 1.1 * size);
  EXPECT_FALSE(CheckBoneMotions(model, bones, "z.txt", &error));
  EXPECT_EQ(error.rfind("z.txt: bone 'base' moves the model's centre by ", 0), 0u) << error;
  bones[0].translation = Eigen::Vector3d(std::nan(""), 0, 0);
  EXPECT_FALSE(CheckBoneMotions(model, bones, "z.txt", &error));
}

}  // namespace
}  // namespace aqs
