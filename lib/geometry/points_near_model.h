#ifndef AQS_GEOMETRY_POINTS_NEAR_MODEL_H_
#define AQS_GEOMETRY_POINTS_NEAR_MODEL_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/rigid_transform.h"

namespace aqs {

// A model's size: the diagonal of the bounding box of its neutral surface's vertices
// `neutral` (3 x n, one column per vertex); 0 without vertices.
double ModelSize(const Eigen::Matrix3Xd& neutral);

// The centre of the bounding box of the neutral surface's vertices `neutral` (3 x n); the
// origin without vertices.
Eigen::Vector3d ModelCentre(const Eigen::Matrix3Xd& neutral);

// How far the rigid `motion` (a bone's) carries the model's centre: |R c + t - c|, c =
// ModelCentre(neutral).
double CentreDisplacement(const Eigen::Matrix3Xd& neutral, const RigidTransform& motion);

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

// A fit target's points must lie, in the median, within this many model sizes of the
// neutral: a body with fixed vertices does not move that far, and a target farther away
// is in another unit (millimetres for centimetres) or frame; fitting it runs on for
// minutes towards a pose no solve reaches.
constexpr double kMaxMedianOffsetInModelSizes = 1.0;

// Checks the median distance of `points` (3 x n) to the neutral surface's vertices
// `neutral`: to vertex vertices[i] for point i (markers, poses: `vertices` has n
// entries), or, with `vertices` empty, to the nearest neutral vertex (a scan; at most
// 2,000 points, evenly spaced, are measured). Returns false, if the median is above
// kMaxMedianOffsetInModelSizes model sizes, with *error naming `path`, the median and
// the model's size. With no points or no neutral vertices every target passes. The
// vertices must be neutral vertices (CHECK: callers read them from validated files).
bool CheckTargetOffsetFromModel(const std::string& path, const Eigen::Matrix3Xd& neutral,
                                const std::vector<int>& vertices,
                                const Eigen::Matrix3Xd& points, std::string* error);

}  // namespace aqs

#endif  // AQS_GEOMETRY_POINTS_NEAR_MODEL_H_
