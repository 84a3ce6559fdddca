#include "prepare/mirror_poses.h"

#include <cmath>
#include <limits>

#include <glog/logging.h>

#include "geometry/points_near_model.h"
#include "geometry/triangle_grid.h"
#include "util/option_checks.h"

namespace aqs {
namespace {

// The reflection of a point.
Eigen::Vector3d Reflect(const Eigen::Vector3d& x, int axis, double plane) {
  Eigen::Vector3d y = x;
  y[axis] = 2.0 * plane - x[axis];
  return y;
}

}  // namespace

bool MirrorOptions::Validate(std::string* error) const {
  return OptionChecks()
      .IntInRange("axis", axis, -1, 2)
      .Require(std::isfinite(plane), "plane must be finite (is " + OptionValue(plane) + ")")
      .InRange("tolerance", tolerance, 1e-9, 0.1)
      .InRange("same_fraction", same_fraction, 0.0, 1.0)
      .Done(error);
}

bool MirrorVertexMap(const Eigen::Matrix3Xd& points, int axis, double plane, double tolerance,
                     std::vector<int>* map, std::string* error) {
  CHECK(axis >= 0 && axis < 3 && tolerance > 0.0);
  const int n = static_cast<int>(points.cols());
  map->assign(n, -1);
  if (n == 0) return true;
  // The points as degenerate triangles (i, i, i) in a grid of cells of the tolerance.
  const Eigen::Vector3d lowest = points.rowwise().minCoeff().array() - tolerance;
  const Eigen::Vector3d highest = points.rowwise().maxCoeff().array() + tolerance;
  CHECK_LT((highest - lowest).maxCoeff() / tolerance, 2e9) << "cell indices would overflow";
  Eigen::Matrix3Xi singletons(3, n);
  for (int i = 0; i < n; ++i) singletons.col(i).setConstant(i);
  const TriangleGrid grid(points, singletons, tolerance);
  std::vector<int> marks, near;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d y = Reflect(points.col(i), axis, plane);
    double best = std::numeric_limits<double>::infinity();
    if ((y.array() >= lowest.array()).all() && (y.array() <= highest.array()).all()) {
      near.clear();
      grid.Near(y, i, &marks, &near);
      for (const int j : near) {
        const double d = (points.col(j) - y).norm();
        if (d < best) {
          best = d;
          (*map)[i] = j;
        }
      }
    }
    if (!(best <= tolerance)) {
      *error = "vertex " + std::to_string(i) + " has no mirror image: no vertex lies within " +
               OptionValue(tolerance) + " of its reflection in the plane " + "xyz"[axis] +
               " = " + OptionValue(plane);
      return false;
    }
  }
  for (int i = 0; i < n; ++i) {
    if ((*map)[(*map)[i]] != i) {
      *error = "vertices " + std::to_string(i) + " and " + std::to_string((*map)[i]) +
               " are not each other's mirror image (vertices closer together than " +
               OptionValue(tolerance) + "?)";
      return false;
    }
  }
  return true;
}

Eigen::Matrix3Xd MirrorPoseSurface(const Eigen::Matrix3Xd& neutral, const Eigen::Matrix3Xd& pose,
                                   const std::vector<int>& map, int axis) {
  CHECK_EQ(neutral.cols(), pose.cols());
  CHECK_EQ(static_cast<Eigen::Index>(map.size()), neutral.cols());
  Eigen::Matrix3Xd image(3, neutral.cols());
  for (Eigen::Index i = 0; i < neutral.cols(); ++i) {
    Eigen::Vector3d displacement = pose.col(map[i]) - neutral.col(map[i]);
    displacement[axis] = -displacement[axis];
    image.col(i) = neutral.col(i) + displacement;
  }
  return image;
}

RigidTransform MirrorRigidTransform(const RigidTransform& transform, int axis, double plane) {
  CHECK(axis >= 0 && axis < 3);
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m(axis, axis) = -1.0;
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  b[axis] = 2.0 * plane;
  RigidTransform image;
  image.rotation = m * transform.rotation * m;
  image.translation = m * transform.rotation * b + m * transform.translation + b;
  return image;
}

bool AddMirrorPoses(const MirrorOptions& options, ActiveModel* model, std::vector<int>* sources,
                    std::ostream& log, std::string* error) {
  CHECK(options.enabled());
  sources->clear();
  const Eigen::Matrix3Xd& neutral = model->neutral.vertices;
  const double diagonal = ModelSize(neutral);
  std::vector<int> map;
  if (!MirrorVertexMap(neutral, options.axis, options.plane, options.tolerance * diagonal, &map,
                       error)) {
    *error = "the neutral surface is not mirror-symmetric (--mirror_poses): " + *error;
    return false;
  }
  std::vector<TrainingPose> images;  // appended after the loop (model->poses stays put)
  for (int p = 0; p < model->num_poses(); ++p) {
    const TrainingPose& pose = model->poses[p];
    const Eigen::Matrix3Xd image = MirrorPoseSurface(neutral, pose.surface, map, options.axis);
    const double moved = (pose.surface - neutral).colwise().norm().mean();
    const double differs = (image - pose.surface).colwise().norm().mean();
    if (!(differs > options.same_fraction * moved)) {
      log << "  " << pose.name << ": symmetric (its image differs by " << differs
          << " on average, it moves " << moved << "), no image\n";
      continue;
    }
    TrainingPose mirrored;
    mirrored.name = "mirror_" + pose.name;
    for (const TrainingPose& other : model->poses) {
      if (other.name == mirrored.name) {
        *error = "pose '" + pose.name + "': its mirror image's name '" + mirrored.name +
                 "' is a given pose's (--mirror_poses)";
        return false;
      }
    }
    mirrored.surface = image;
    log << "  " << pose.name << ": mirror image " << mirrored.name << " (differs by " << differs
        << " on average, it moves " << moved << ")\n";
    images.push_back(std::move(mirrored));
    sources->push_back(p);
  }
  model->poses.insert(model->poses.end(), images.begin(), images.end());
  return true;
}

void MirrorBoneTransforms(const MirrorOptions& options, const std::vector<int>& sources,
                          int first, ActiveModel* model) {
  CHECK(options.enabled());
  for (Bone& bone : model->bones) {
    CHECK_EQ(static_cast<int>(bone.pose_transforms.size()), model->num_poses());
    for (size_t k = 0; k < sources.size(); ++k) {
      bone.pose_transforms[first + k] = MirrorRigidTransform(
          bone.pose_transforms[sources[k]], options.axis, options.plane);
    }
  }
}

}  // namespace aqs
