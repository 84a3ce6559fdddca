#include "prepare/halfway_poses.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <glog/logging.h>

#include "geometry/points_near_model.h"
#include "geometry/rigid_transform.h"
#include "util/option_checks.h"

namespace aqs {

bool HalfwayOptions::Validate(std::string* error) const {
  // 0 is refused: a bone whose fitted motion is round-off would get a halfway pose.
  return OptionChecks()
      .Require(min_bone_motion > 0.0 && min_bone_motion <= 1.0,
               "min_bone_motion must be finite and in (0, 1] (is " + OptionValue(min_bone_motion) +
                   ")")
      .Done(error);
}

double LargestBoneMotion(const ActiveModel& model, int bone, int pose) {
  const Bone& b = model.bones[bone];
  const RigidTransform& transform = b.pose_transforms[pose];
  double largest = 0.0;
  for (int v : b.vertices) {
    const Eigen::Vector3d x = model.mesh.vertices.col(v);
    largest = std::max(largest, (transform.ApplyToPoint(x) - x).norm());
  }
  return largest;
}

bool AddHalfwayPoses(const HalfwayOptions& options, ActiveModel* model, int* added,
                     std::ostream& log, std::string* error) {
  CHECK(options.enabled);
  std::string invalid;
  DCHECK(options.Validate(&invalid)) << invalid;
  *added = 0;
  const int given = model->num_poses();
  for (const Bone& bone : model->bones) {
    CHECK_EQ(static_cast<int>(bone.pose_transforms.size()), given);
  }
  const Eigen::Matrix3Xd& rest = model->mesh.vertices;
  const double diagonal = ModelSize(rest);
  const double threshold = options.min_bone_motion * diagonal;
  const Eigen::Matrix3Xd& neutral = model->neutral.vertices;
  std::vector<int> sources;
  for (int p = 0; p < given; ++p) {
    double largest = 0.0;
    for (int b = 0; b < static_cast<int>(model->bones.size()); ++b) {
      largest = std::max(largest, LargestBoneMotion(*model, b, p));
    }
    if (!(largest > threshold)) continue;
    const std::string name = "half_" + model->poses[p].name;
    for (const TrainingPose& other : model->poses) {
      if (other.name == name) {
        *error = "pose '" + model->poses[p].name + "': its halfway pose's name '" + name +
                 "' is a given pose's (--halfway_poses)";
        return false;
      }
    }
    log << "  " << model->poses[p].name << ": halfway pose " << name << " (its bones move up to "
        << largest << ")\n";
    sources.push_back(p);
  }
  for (int p : sources) {
    TrainingPose half;
    half.name = "half_" + model->poses[p].name;
    half.surface = neutral + 0.5 * (model->poses[p].surface - neutral);
    model->poses.push_back(std::move(half));
    for (Bone& bone : model->bones) {
      bone.pose_transforms.push_back(InterpolateRigidTransform(bone.pose_transforms[p], 0.5));
    }
  }
  *added = static_cast<int>(sources.size());
  return true;
}

}  // namespace aqs
