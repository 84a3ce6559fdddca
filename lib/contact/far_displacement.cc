#include "contact/far_displacement.h"

#include <algorithm>

#include <glog/logging.h>

#include "geometry/triangle_grid.h"

namespace aqs {

double MaxFarDisplacement(const Eigen::Matrix3Xd& surface, const Eigen::VectorXd& moved,
                          const std::vector<char>& touched, double far_distance) {
  CHECK_EQ(moved.size(), surface.cols());
  CHECK_EQ(touched.size(), static_cast<size_t>(surface.cols()));
  CHECK_GT(far_distance, 0.0);
  // The touched points as degenerate triangles (v, v, v) in cells of the far distance:
  // every touched point within it lies in the 27 cells about a point's own.
  std::vector<int> touched_points;
  for (Eigen::Index i = 0; i < surface.cols(); ++i) {
    if (touched[i]) touched_points.push_back(static_cast<int>(i));
  }
  Eigen::Matrix3Xi points(3, touched_points.size());
  for (size_t k = 0; k < touched_points.size(); ++k) points.col(k).setConstant(touched_points[k]);
  const TriangleGrid grid(surface, points, far_distance);
  std::vector<int> marks, near;
  double largest = 0.0;
  for (Eigen::Index i = 0; i < surface.cols(); ++i) {
    grid.Near(surface.col(i), static_cast<int>(i), &marks, &near);
    const bool far = std::none_of(near.begin(), near.end(), [&](int k) {
      return (surface.col(i) - surface.col(touched_points[k])).norm() <= far_distance;
    });
    if (far) largest = std::max(largest, moved[i]);
  }
  return largest;
}

}  // namespace aqs
