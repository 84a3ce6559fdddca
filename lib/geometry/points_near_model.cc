#include "geometry/points_near_model.h"

#include <algorithm>
#include <sstream>

namespace aqs {

bool CheckPointsNearModel(const std::string& path, const Eigen::Matrix3Xd& neutral,
                          const Eigen::Matrix3Xd& points, std::string* error) {
  if (neutral.cols() == 0) return true;
  const Eigen::Vector3d lower = neutral.rowwise().minCoeff();
  const Eigen::Vector3d upper = neutral.rowwise().maxCoeff();
  const Eigen::Vector3d centre = 0.5 * (lower + upper);
  const double size = std::max((upper - lower).norm(), 1e-300);
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

}  // namespace aqs
