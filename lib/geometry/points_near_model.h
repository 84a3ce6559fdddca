#ifndef AQS_GEOMETRY_POINTS_NEAR_MODEL_H_
#define AQS_GEOMETRY_POINTS_NEAR_MODEL_H_

#include <string>

#include <Eigen/Core>

namespace aqs {

// Surfaces and points given for a model (poses, held-out poses, fit targets) must lie
// within this many model sizes (the diagonal of the neutral's bounding box) of the
// neutral's bounding-box centre: farther, they are in another frame or unit, or broken
// (1e20 in a pose, 1e154 in a scan), and fitting or simulating towards them overflows or
// runs on.
constexpr double kMaxDistanceInModelSizes = 1e3;

// Checks every column of `points` against kMaxDistanceInModelSizes for the neutral
// surface's vertices `neutral`. Returns false with *error naming `path`, the point, its
// distance and the model's size. With no neutral vertices there is nothing to measure
// against, and every point passes.
bool CheckPointsNearModel(const std::string& path, const Eigen::Matrix3Xd& neutral,
                          const Eigen::Matrix3Xd& points, std::string* error);

}  // namespace aqs

#endif  // AQS_GEOMETRY_POINTS_NEAR_MODEL_H_
