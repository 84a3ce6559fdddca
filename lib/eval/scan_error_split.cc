#include "eval/scan_error_split.h"

#include <algorithm>
#include <cmath>
#include <limits>

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

}  // namespace

double MedianPointSpacing(const Eigen::Matrix3Xd& cloud) {
  const Eigen::Index m = cloud.cols();
  CHECK_GE(m, 2);
  const double diagonal = (cloud.rowwise().maxCoeff() - cloud.rowwise().minCoeff()).norm();
  if (!(diagonal > 0)) return 0.0;  // all points coincide
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
