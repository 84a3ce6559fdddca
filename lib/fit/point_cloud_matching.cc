#include "fit/point_cloud_matching.h"

#include <algorithm>
#include <vector>

#include "geometry/triangle_bvh.h"

namespace aqs {


// Each scan point matched to the closest point of `surface` (triangles of the
// neutral), with robust weights: the target of one matching round.
FitTarget MatchPointCloud(const Eigen::Matrix3Xd& points, const Eigen::Matrix3Xd& surface,
                          const Eigen::Matrix3Xi& triangles, const PointCloudFitOptions& options,
                          int num_threads, int* used, double* mean_distance) {
  const TriangleBvh bvh(surface, triangles);
  const std::vector<ClosestPointResult> closest = bvh.ClosestPoints(points, num_threads);
  FitTarget target;
  const Eigen::Index m = points.cols();
  target.vertices.resize(3, m);
  target.barycentric.resize(3, m);
  target.positions = points;
  target.weights.resize(m);
  if (options.tangential_weight < 1.0) {
    target.normals.resize(3, m);
    target.tangential_weight = std::max(options.tangential_weight, 0.0);
  }
  *used = 0;
  double sum = 0.0;
  for (Eigen::Index i = 0; i < m; ++i) {
    const ClosestPointResult& c = closest[i];
    target.vertices.col(i) = triangles.col(c.triangle);
    target.barycentric.col(i) = c.barycentric;
    if (target.normals.cols() == m) {
      const Eigen::Vector3i t = triangles.col(c.triangle);
      const Eigen::Vector3d n = (surface.col(t[1]) - surface.col(t[0]))
                                    .cross(surface.col(t[2]) - surface.col(t[0]));
      const double length = n.norm();
      target.normals.col(i) = length > 0 ? Eigen::Vector3d(n / length) : Eigen::Vector3d::Zero();
    }
    double w = 1.0;
    if (options.max_distance > 0 && c.distance > options.max_distance) w = 0.0;
    if (w > 0 && options.robust_scale > 0) {
      const double r = c.distance / options.robust_scale;
      w = 1.0 / (1.0 + r * r);
    }
    target.weights[i] = w;
    if (w > 0) {
      ++*used;
      sum += c.distance;
    }
  }
  *mean_distance = *used > 0 ? sum / *used : 0.0;
  return target;
}

double CloudDataTerm(const Eigen::Matrix3Xd& points, const Eigen::Matrix3Xd& surface,
                     const Eigen::Matrix3Xi& triangles, const PointCloudFitOptions& options,
                     int num_threads, int* within) {
  const TriangleBvh bvh(surface, triangles);
  const std::vector<ClosestPointResult> closest = bvh.ClosestPoints(points, num_threads);
  const double cap = options.max_distance;
  const double s = options.robust_scale;
  double sum = 0.0;
  int count = 0;
  for (const ClosestPointResult& c : closest) {
    double d = c.distance;
    if (cap > 0 && d > cap) {
      d = cap;
    } else {
      ++count;
    }
    const double r = RobustDistance(d, s, nullptr);
    sum += r * r;
  }
  if (within != nullptr) *within = count;
  return points.cols() > 0 ? sum / static_cast<double>(points.cols()) : 0.0;
}

}  // namespace aqs
