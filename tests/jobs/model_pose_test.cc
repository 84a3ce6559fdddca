// What a job simulates with a trained model (jobs/model_pose.h): a training pose by
// name, and the checks that refuse latents and bone motions no simulation should chase.

#include "jobs/model_pose.h"

#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/fit_fixtures.h"
#include "testing/temp_dir.h"

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

// A latent file records the model it was fitted with: this model's passes, another
// model's is refused, a latent of another training of this model passes with a warning,
// and an older file without the record passes.
TEST_F(ModelPoseTest, LatentFilesOfAnotherModelAreRefusedAndOfAnotherTrainingWarned) {
  const ActiveModel& model = *model_;
  testing::TempDir dir;
  const std::string path = dir.File("z.txt");
  std::vector<RigidTransform> bones(1);
  auto resolve = [&](const LatentFileModel& origin, ModelPose* pose, std::string* error) {
    EXPECT_TRUE(WriteLatentFile(path, model.latents.col(0), {model.bones[0].name}, bones, "",
                                origin, error))
        << *error;
    return ResolveModelPose(model, path, "", pose, error);
  };
  ModelPose pose;
  std::string error;
  EXPECT_TRUE(resolve(LatentFileModelOf(model), &pose, &error)) << error;
  EXPECT_EQ(pose.warning, "");
  EXPECT_TRUE(resolve(LatentFileModel(), &pose, &error)) << error;
  EXPECT_EQ(pose.warning, "");
  ActiveModel retrained = model;
  retrained.decoder_params *= 1.01;
  EXPECT_TRUE(resolve(LatentFileModelOf(retrained), &pose, &error)) << error;
  EXPECT_NE(pose.warning.find("z.txt: fitted with another learned state of this model"),
            std::string::npos)
      << pose.warning;
  ActiveModel other = model;
  other.mesh.vertices(0, 0) += 1e-3;
  EXPECT_FALSE(resolve(LatentFileModelOf(other), &pose, &error));
  EXPECT_NE(error.find("z.txt: a latent of another model"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
