#include "eval/scan_error_split.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <glog/logging.h>

#include "geometry/triangle_grid.h"

namespace aqs {
namespace {

// The points of a cloud as degenerate triangles (i, i, i), for a TriangleGrid.
Eigen::Matrix3Xi PointTriangles(Eigen::Index count) {
  Eigen::Matrix3Xi triangles(3, count);
  for (Eigen::Index i = 0; i < count; ++i) triangles.col(i).setConstant(static_cast<int>(i));
  return triangles;
}

// The diagonal of the box between the kTrimmedFraction and 1 - kTrimmedFraction
// quantiles of each coordinate of `cloud` (3 x M): the extent of the bulk of a scan,
// which a few stray points far from it do not change.
constexpr double kTrimmedFraction = 0.02;

double TrimmedDiagonal(const Eigen::Matrix3Xd& cloud) {
  const Eigen::Index m = cloud.cols();
  const Eigen::Index low = static_cast<Eigen::Index>(kTrimmedFraction * (m - 1));
  const Eigen::Index high = m - 1 - low;
  std::vector<double> values(m);
  double squared = 0.0;
  for (int axis = 0; axis < 3; ++axis) {
    for (Eigen::Index i = 0; i < m; ++i) values[i] = cloud(axis, i);
    std::nth_element(values.begin(), values.begin() + low, values.end());
    const double lo = values[low];
    std::nth_element(values.begin(), values.begin() + high, values.end());
    const double hi = values[high];
    squared += (hi - lo) * (hi - lo);
  }
  return std::sqrt(squared);
}

// The distinct columns of `cloud` (3 x M), in lexicographic order.
Eigen::Matrix3Xd DistinctPoints(const Eigen::Matrix3Xd& cloud) {
  std::vector<Eigen::Index> order(cloud.cols());
  for (Eigen::Index i = 0; i < cloud.cols(); ++i) order[i] = i;
  const auto less = [&](Eigen::Index i, Eigen::Index j) {
    return std::lexicographical_compare(cloud.col(i).data(), cloud.col(i).data() + 3,
                                        cloud.col(j).data(), cloud.col(j).data() + 3);
  };
  std::sort(order.begin(), order.end(), less);
  Eigen::Matrix3Xd distinct(3, cloud.cols());
  Eigen::Index count = 0;
  for (Eigen::Index k = 0; k < static_cast<Eigen::Index>(order.size()); ++k) {
    if (count > 0 && cloud.col(order[k]) == distinct.col(count - 1)) continue;
    distinct.col(count++) = cloud.col(order[k]);
  }
  return distinct.leftCols(count);
}

}  // namespace

double MedianPointSpacing(const Eigen::Matrix3Xd& all_points) {
  CHECK_GE(all_points.cols(), 2);
  const Eigen::Matrix3Xd cloud = DistinctPoints(all_points);
  const Eigen::Index m = cloud.cols();
  if (m < 2) return 0.0;  // all points coincide
  double diagonal = TrimmedDiagonal(cloud);
  if (!(diagonal > 0)) {  // the bulk at one position: the whole box
    diagonal = (cloud.rowwise().maxCoeff() - cloud.rowwise().minCoeff()).norm();
  }
  const double cell = diagonal / std::sqrt(static_cast<double>(m));
  const TriangleGrid grid(cloud, PointTriangles(m), cell);
  std::vector<int> marks, near;
  std::vector<double> nearest(m);
  for (Eigen::Index i = 0; i < m; ++i) {
    grid.Near(cloud.col(i), static_cast<int>(i), &marks, &near);
    double best = std::numeric_limits<double>::infinity();
    for (int j : near) {
      if (j != i) best = std::min(best, (cloud.col(j) - cloud.col(i)).norm());
    }
    nearest[i] = std::isfinite(best) ? best : cell;
  }
  std::nth_element(nearest.begin(), nearest.begin() + m / 2, nearest.end());
  return nearest[m / 2];
}

std::vector<int> VerticesNearCloud(const Eigen::Matrix3Xd& vertices,
                                   const std::vector<int>& candidates,
                                   const Eigen::Matrix3Xd& cloud, double radius) {
  CHECK_GT(radius, 0.0);
  std::vector<int> near_cloud;
  if (cloud.cols() == 0) return near_cloud;
  const TriangleGrid grid(cloud, PointTriangles(cloud.cols()), radius);
  std::vector<int> marks, near;
  int stamp = 0;
  for (int v : candidates) {
    grid.Near(vertices.col(v), stamp++, &marks, &near);
    for (int j : near) {
      if ((cloud.col(j) - vertices.col(v)).norm() <= radius) {
        near_cloud.push_back(v);
        break;
      }
    }
  }
  return near_cloud;
}

std::vector<int> ScannedVertices(const Eigen::Matrix3Xd& vertices,
                                 const std::vector<int>& candidates,
                                 const Eigen::Matrix3Xd& cloud) {
  if (cloud.cols() < 2) return {};
  const double spacing = MedianPointSpacing(cloud);
  if (!(spacing > 0)) return {};
  return VerticesNearCloud(vertices, candidates, cloud, kScannedSpacings * spacing);
}

NormalTangentialError SplitError(const Eigen::Matrix3Xd& surface, const Eigen::Matrix3Xd& truth,
                                 const Eigen::Matrix3Xd& normals,
                                 const std::vector<int>& vertices) {
  CHECK_EQ(surface.cols(), truth.cols());
  CHECK_EQ(normals.cols(), truth.cols());
  NormalTangentialError split;
  if (vertices.empty()) return split;
  for (int v : vertices) {
    const Eigen::Vector3d d = surface.col(v) - truth.col(v);
    const double along = d.dot(normals.col(v));
    split.normal += std::abs(along);
    split.tangential += (d - along * normals.col(v)).norm();
    split.total += d.norm();
  }
  const double n = static_cast<double>(vertices.size());
  split.normal /= n;
  split.tangential /= n;
  split.total /= n;
  return split;
}

}  // namespace aqs
