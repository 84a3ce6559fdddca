#include "geometry/points_near_model.h"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <glog/logging.h>

namespace aqs {

double ModelSize(const Eigen::Matrix3Xd& neutral) {
  if (neutral.cols() == 0) return 0.0;
  return (neutral.rowwise().maxCoeff() - neutral.rowwise().minCoeff()).norm();
}

Eigen::Vector3d ModelCentre(const Eigen::Matrix3Xd& neutral) {
  if (neutral.cols() == 0) return Eigen::Vector3d::Zero();
  return 0.5 * (neutral.rowwise().minCoeff() + neutral.rowwise().maxCoeff());
}

double CentreDisplacement(const Eigen::Matrix3Xd& neutral, const RigidTransform& motion) {
  const Eigen::Vector3d centre = ModelCentre(neutral);
  return (motion.rotation * centre + motion.translation - centre).norm();
}

bool CheckPointsNearModel(const std::string& path, const Eigen::Matrix3Xd& neutral,
                          const Eigen::Matrix3Xd& points, std::string* error) {
  if (neutral.cols() == 0) return true;
  const Eigen::Vector3d centre = ModelCentre(neutral);
  const double size = std::max(ModelSize(neutral), 1e-300);
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    const double distance = (points.col(i) - centre).stableNorm();
    if (!(distance <= kMaxDistanceInModelSizes * size)) {
      std::ostringstream out;
      out.precision(4);
      out << path << ": point " << i << " (" << points(0, i) << " " << points(1, i) << " "
          << points(2, i) << ") is " << distance << " from the model, more than "
          << kMaxDistanceInModelSizes << " times the model's size (" << size
          << "): is it in another frame or unit?";
      *error = out.str();
      return false;
    }
  }
  return true;
}

bool CheckTargetOffsetFromModel(const std::string& path, const Eigen::Matrix3Xd& neutral,
                                const std::vector<int>& vertices,
                                const Eigen::Matrix3Xd& points, std::string* error) {
  if (neutral.cols() == 0 || points.cols() == 0) return true;
  if (!vertices.empty()) CHECK_EQ(static_cast<Eigen::Index>(vertices.size()), points.cols());
  for (int v : vertices) CHECK(v >= 0 && v < neutral.cols()) << "neutral vertex " << v;
  const double size = std::max(ModelSize(neutral), 1e-300);
  constexpr Eigen::Index kMaxMeasured = 2000;
  // Rounded up: at most kMaxMeasured points (3,999 points had stride 1).
  const Eigen::Index stride =
      vertices.empty()
          ? std::max<Eigen::Index>(1, (points.cols() + kMaxMeasured - 1) / kMaxMeasured)
          : 1;
  std::vector<double> distances;
  for (Eigen::Index i = 0; i < points.cols(); i += stride) {
    if (!vertices.empty()) {
      distances.push_back((points.col(i) - neutral.col(vertices[i])).norm());
    } else {
      distances.push_back(
          std::sqrt((neutral.colwise() - points.col(i)).colwise().squaredNorm().minCoeff()));
    }
  }
  std::nth_element(distances.begin(), distances.begin() + distances.size() / 2,
                   distances.end());
  const double median = distances[distances.size() / 2];
  if (median <= kMaxMedianOffsetInModelSizes * size) return true;
  std::ostringstream out;
  out.precision(4);
  out << path << ": its points lie a median " << median << " from "
      << (vertices.empty() ? "the model's nearest vertices" : "their vertices on the model")
      << ", " << median / size << " times the model's size (" << size
      << "): is it in another unit (millimetres for centimetres?) or frame?";
  *error = out.str();
  return false;
}

}  // namespace aqs
