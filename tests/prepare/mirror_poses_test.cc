#include "prepare/mirror_poses.h"

#include <cmath>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "testing/test_surfaces.h"

namespace aqs {
namespace {

// The reflection S(x) in the plane x[axis] = plane.
Eigen::Matrix3Xd Reflected(const Eigen::Matrix3Xd& points, int axis, double plane) {
  Eigen::Matrix3Xd out = points;
  out.row(axis) = (2.0 * plane - points.row(axis).array()).matrix();
  return out;
}

// A twist about the z axis by angle * z.
Eigen::Matrix3Xd Twisted(const Eigen::Matrix3Xd& points, double angle) {
  Eigen::Matrix3Xd out = points;
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const double a = angle * points(2, i);
    out(0, i) = std::cos(a) * points(0, i) - std::sin(a) * points(1, i);
    out(1, i) = std::sin(a) * points(0, i) + std::cos(a) * points(1, i);
  }
  return out;
}

// The icosphere (642 vertices, radius 2) is symmetric in x = 0, y = 0 and z = 0.
class MirrorPosesTest : public ::testing::Test {
 protected:
  MirrorPosesTest() : sphere_(testing::Icosphere(3, 2.0)) {}

  // A model of the sphere with these poses.
  ActiveModel SphereModel(const std::vector<TrainingPose>& poses) const {
    ActiveModel model;
    model.neutral = sphere_;
    model.poses = poses;
    return model;
  }
  // The pose `name`: the sphere twisted by angle * z.
  TrainingPose Twist(const std::string& name, double angle) const {
    TrainingPose pose;
    pose.name = name;
    pose.surface = Twisted(sphere_.vertices, angle);
    return pose;
  }
  // Mirror images in x = 0.
  static MirrorOptions XMirror() {
    MirrorOptions options;
    options.axis = 0;
    return options;
  }

  SurfaceMesh sphere_;
};

TEST_F(MirrorPosesTest, VertexMapIsTheReflectionAndItsOwnInverse) {
  for (int axis = 0; axis < 3; ++axis) {
    for (const double plane : {0.0, 0.75}) {
      // Shift the sphere so that its plane of symmetry is the given one.
      Eigen::Matrix3Xd points = sphere_.vertices;
      points.row(axis).array() += plane;
      std::vector<int> map;
      std::string error;
      ASSERT_TRUE(MirrorVertexMap(points, axis, plane, 1e-6, &map, &error)) << error;
      const Eigen::Matrix3Xd reflected = Reflected(points, axis, plane);
      int on_plane = 0;
      for (Eigen::Index i = 0; i < points.cols(); ++i) {
        EXPECT_EQ(map[map[i]], i);
        EXPECT_LT((points.col(map[i]) - reflected.col(i)).norm(), 1e-9) << i;
        on_plane += map[i] == i;
      }
      EXPECT_GT(on_plane, 0);  // vertices on the plane are their own images
      EXPECT_LT(on_plane, points.cols());
    }
  }
}

TEST_F(MirrorPosesTest, AnAsymmetricVertexIsNamed) {
  Eigen::Matrix3Xd points = sphere_.vertices;
  points(0, 17) += 0.05;
  std::vector<int> map;
  std::string error;
  EXPECT_FALSE(MirrorVertexMap(points, 0, 0.0, 1e-3, &map, &error));
  EXPECT_NE(error.find("vertex "), std::string::npos) << error;
  EXPECT_NE(error.find("no mirror image"), std::string::npos) << error;
  // Within a larger tolerance the same points are accepted.
  EXPECT_TRUE(MirrorVertexMap(points, 0, 0.0, 0.1, &map, &error)) << error;
}

// The image of a twist by angle(z) in x = 0 is the twist by -angle(z); the image of the
// image is the pose, and the neutral is its own image.
TEST_F(MirrorPosesTest, ImageOfATwistIsTheOppositeTwist) {
  std::vector<int> map;
  std::string error;
  ASSERT_TRUE(MirrorVertexMap(sphere_.vertices, 0, 0.0, 1e-6, &map, &error)) << error;
  const Eigen::Matrix3Xd& neutral = sphere_.vertices;
  const Eigen::Matrix3Xd pose = Twisted(neutral, 0.2);
  const Eigen::Matrix3Xd image = MirrorPoseSurface(neutral, pose, map, 0);
  EXPECT_LT((image - Twisted(neutral, -0.2)).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_LT((MirrorPoseSurface(neutral, image, map, 0) - pose).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((MirrorPoseSurface(neutral, neutral, map, 0) - neutral).cwiseAbs().maxCoeff(), 1e-15);
}

// S T S maps S p to S T p, is a proper rigid motion, and is its own image's image.
TEST(MirrorRigidTransformTest, ConjugatesByTheReflection) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal;
  for (int trial = 0; trial < 6; ++trial) {
    const int axis = trial % 3;
    const double plane = trial < 3 ? 0.0 : 0.7;
    RigidTransform transform;
    transform.rotation =
        Eigen::AngleAxisd(normal(rng), Eigen::Vector3d(normal(rng), normal(rng), normal(rng))
                                           .normalized())
            .toRotationMatrix();
    transform.translation = Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    const RigidTransform image = MirrorRigidTransform(transform, axis, plane);
    Eigen::Matrix3Xd points(3, 5);
    for (int i = 0; i < points.size(); ++i) points.data()[i] = normal(rng);
    const Eigen::Matrix3Xd expected = Reflected(transform.Apply(points), axis, plane);
    EXPECT_LT((image.Apply(Reflected(points, axis, plane)) - expected).norm(), 1e-12);
    EXPECT_NEAR(image.rotation.determinant(), 1.0, 1e-12);
    EXPECT_LT((image.rotation.transpose() * image.rotation - Eigen::Matrix3d::Identity()).norm(),
              1e-12);
    const RigidTransform back = MirrorRigidTransform(image, axis, plane);
    EXPECT_LT((back.rotation - transform.rotation).norm(), 1e-12);
    EXPECT_LT((back.translation - transform.translation).norm(), 1e-12);
  }
}

// A model with a symmetric stretch and a twist: only the twist gets an image, and the
// bone transforms of the image are the mirrored ones of its source.
TEST_F(MirrorPosesTest, AddsImagesOfAsymmetricPosesOnlyAndMirrorsTheirBones) {
  TrainingPose stretch;
  stretch.name = "stretch";
  stretch.surface = sphere_.vertices;
  stretch.surface.row(0) *= 1.06;
  ActiveModel model = SphereModel({stretch, Twist("twist", 0.1)});
  const MirrorOptions options = XMirror();
  std::vector<int> sources;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(AddMirrorPoses(options, &model, &sources, log, &error)) << error;
  ASSERT_EQ(model.num_poses(), 3) << log.str();
  EXPECT_EQ(model.poses[2].name, "mirror_twist");
  EXPECT_EQ(sources, std::vector<int>({1}));
  EXPECT_LT((model.poses[2].surface - Twisted(sphere_.vertices, -0.1)).cwiseAbs().maxCoeff(),
            1e-9);
  EXPECT_NE(log.str().find("stretch: symmetric"), std::string::npos) << log.str();

  Bone bone;
  bone.name = "jaw";
  RigidTransform moved;
  moved.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  moved.translation = Eigen::Vector3d(0.2, -0.1, 0.4);
  bone.pose_transforms = {RigidTransform(), moved, RigidTransform()};
  model.bones.push_back(bone);
  MirrorBoneTransforms(options, sources, 2, &model);
  const RigidTransform expected = MirrorRigidTransform(moved, 0, 0.0);
  EXPECT_EQ(model.bones[0].pose_transforms[2].rotation, expected.rotation);
  EXPECT_EQ(model.bones[0].pose_transforms[2].translation, expected.translation);
  EXPECT_EQ(model.bones[0].pose_transforms[1].translation, moved.translation);
}

TEST_F(MirrorPosesTest, RefusesAnAsymmetricNeutralAndATakenName) {
  ActiveModel model = SphereModel({Twist("twist", 0.1), Twist("mirror_twist", 0.1)});
  const MirrorOptions options = XMirror();
  std::vector<int> sources;
  std::ostringstream log;
  std::string error;
  EXPECT_FALSE(AddMirrorPoses(options, &model, &sources, log, &error));
  EXPECT_NE(error.find("'mirror_twist' is a given pose's"), std::string::npos) << error;

  model.poses = {Twist("twist", 0.1)};
  model.neutral.vertices(0, 5) += 0.2;  // the diagonal is 4: 0.2 is 5% of it
  EXPECT_FALSE(AddMirrorPoses(options, &model, &sources, log, &error));
  EXPECT_NE(error.find("not mirror-symmetric"), std::string::npos) << error;
  EXPECT_NE(error.find("vertex 5"), std::string::npos) << error;
}

TEST(MirrorOptionsTest, ValidateNamesTheBadField) {
  std::string error;
  EXPECT_TRUE(MirrorOptions().Validate(&error)) << error;
  MirrorOptions options;
  options.axis = 3;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("axis"), std::string::npos) << error;
  options = MirrorOptions();
  options.tolerance = 0.0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("tolerance"), std::string::npos) << error;
  options = MirrorOptions();
  options.plane = std::nan("");
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_NE(error.find("plane"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
