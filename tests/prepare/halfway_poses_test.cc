#include "prepare/halfway_poses.h"

#include <cmath>
#include <sstream>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "geometry/rigid_transform.h"

namespace aqs {
namespace {

// A model of the unit cube's 8 corners (diagonal sqrt(3)) with a bone on corners 0..3
// and a second bone on corner 7 that never moves; 12 surface vertices; poses:
//   turn:  the first bone turned 40 degrees about a pivot off the origin;
//   still: no bone moves;
//   nudge: the first bone moved 0.001 (below 1% of the diagonal).
class HalfwayPosesTest : public ::testing::Test {
 protected:
  HalfwayPosesTest() {
    model_.mesh.vertices.resize(3, 8);
    for (int i = 0; i < 8; ++i) {
      model_.mesh.vertices.col(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
    }
    model_.neutral.vertices = Eigen::Matrix3Xd::Random(3, 12);
    Bone moving, fixed;
    moving.name = "jaw";
    moving.vertices = {0, 1, 2, 3};
    fixed.name = "skull";
    fixed.vertices = {7};
    turn_.rotation = Eigen::AngleAxisd(40.0 * M_PI / 180.0,
                                       Eigen::Vector3d(1, 2, 0.5).normalized())
                         .toRotationMatrix();
    const Eigen::Vector3d pivot(0.3, -0.2, 0.8);
    turn_.translation = pivot - turn_.rotation * pivot + Eigen::Vector3d(0.05, 0, 0);
    RigidTransform nudge;
    nudge.translation << 0.001, 0, 0;
    for (const char* name : {"turn", "still", "nudge"}) {
      TrainingPose pose;
      pose.name = name;
      pose.surface = Eigen::Matrix3Xd::Random(3, 12);
      model_.poses.push_back(pose);
    }
    moving.pose_transforms = {turn_, RigidTransform(), nudge};
    fixed.pose_transforms.assign(3, RigidTransform());
    model_.bones = {moving, fixed};
  }

  ActiveModel model_;
  RigidTransform turn_;
};

TEST_F(HalfwayPosesTest, APoseWhoseBonesMoveGetsItsHalfwayPose) {
  HalfwayOptions options;
  options.enabled = true;
  std::ostringstream log;
  std::string error;
  int added = -1;
  const ActiveModel given = model_;
  ASSERT_TRUE(AddHalfwayPoses(options, &model_, &added, log, &error)) << error;
  EXPECT_EQ(added, 1) << log.str();
  ASSERT_EQ(model_.num_poses(), 4);
  const TrainingPose& half = model_.poses[3];
  EXPECT_EQ(half.name, "half_turn");
  EXPECT_TRUE(half.surface.isApprox(
      0.5 * (given.neutral.vertices + given.poses[0].surface), 1e-14));
  EXPECT_EQ(half.target.cols(), 0);
  // The given poses are as they were.
  for (int p = 0; p < 3; ++p) EXPECT_EQ(model_.poses[p].surface, given.poses[p].surface);
  // Every bone has a transform for it: halfway along the screw motion (twice is the
  // whole), and the bone that never moves stays.
  ASSERT_EQ(model_.bones[0].pose_transforms.size(), 4u);
  ASSERT_EQ(model_.bones[1].pose_transforms.size(), 4u);
  const RigidTransform& h = model_.bones[0].pose_transforms[3];
  EXPECT_TRUE((h.rotation * h.rotation).isApprox(turn_.rotation, 1e-12));
  EXPECT_TRUE((h.rotation * h.translation + h.translation).isApprox(turn_.translation, 1e-12));
  EXPECT_NEAR(Eigen::AngleAxisd(h.rotation).angle(), 20.0 * M_PI / 180.0, 1e-12);
  EXPECT_TRUE(model_.bones[1].pose_transforms[3].rotation.isIdentity(0.0));
  EXPECT_TRUE(model_.bones[1].pose_transforms[3].translation.isZero(0.0));
  EXPECT_NE(log.str().find("turn: halfway pose half_turn"), std::string::npos) << log.str();
  // The motion measure: the turned bone's farthest corner, the nudge's 0.001.
  EXPECT_GT(LargestBoneMotion(given, 0, 0), 0.1);
  EXPECT_NEAR(LargestBoneMotion(given, 0, 2), 0.001, 1e-15);
  EXPECT_EQ(LargestBoneMotion(given, 1, 0), 0.0);
}

TEST_F(HalfwayPosesTest, TheThresholdDecidesWhichPosesGetOne) {
  HalfwayOptions options;
  options.enabled = true;
  options.min_bone_motion = 1e-6;  // the nudge's motion too
  std::ostringstream log;
  std::string error;
  int added = 0;
  ASSERT_TRUE(AddHalfwayPoses(options, &model_, &added, log, &error)) << error;
  EXPECT_EQ(added, 2);
  ASSERT_EQ(model_.num_poses(), 5);
  EXPECT_EQ(model_.poses[3].name, "half_turn");
  EXPECT_EQ(model_.poses[4].name, "half_nudge");
  EXPECT_TRUE(model_.bones[0].pose_transforms[4].translation.isApprox(
      Eigen::Vector3d(0.0005, 0, 0), 1e-15));
}

TEST_F(HalfwayPosesTest, AHalfwayNameThatIsTakenIsRefused) {
  model_.poses[1].name = "half_turn";
  HalfwayOptions options;
  options.enabled = true;
  std::ostringstream log;
  std::string error;
  int added = 0;
  EXPECT_FALSE(AddHalfwayPoses(options, &model_, &added, log, &error));
  EXPECT_EQ(error,
            "pose 'turn': its halfway pose's name 'half_turn' is a given pose's "
            "(--halfway_poses)");
  EXPECT_EQ(model_.num_poses(), 3);
}

TEST(HalfwayOptionsTest, MotionThresholdIsAFraction) {
  HalfwayOptions options;
  std::string error;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.min_bone_motion = -0.1;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("min_bone_motion"), std::string::npos) << error;
  options.min_bone_motion = std::nan("");
  EXPECT_FALSE(options.Validate(&error));
  // 0 would give a halfway pose to a bone whose fitted motion is round-off.
  options.min_bone_motion = 0.0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error, "min_bone_motion must be finite and in (0, 1] (is 0)");
  options.min_bone_motion = 1.0;
  EXPECT_TRUE(options.Validate(&error)) << error;
}

}  // namespace
}  // namespace aqs
