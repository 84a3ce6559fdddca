#include "testing/test_surfaces.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>

#include <Eigen/Geometry>

namespace aqs {
namespace testing {

SurfaceMesh Icosphere(int subdivisions, double radius,
                     const Eigen::Vector3d& centre) {
  const double g = (1.0 + std::sqrt(5.0)) / 2.0;
  std::vector<Eigen::Vector3d> points = {{-1, g, 0}, {1, g, 0}, {-1, -g, 0}, {1, -g, 0},
                                         {0, -1, g}, {0, 1, g}, {0, -1, -g}, {0, 1, -g},
                                         {g, 0, -1}, {g, 0, 1}, {-g, 0, -1}, {-g, 0, 1}};
  for (Eigen::Vector3d& p : points) p.normalize();
  std::vector<Eigen::Vector3i> faces = {
      {0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
      {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
      {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}};
  for (int s = 0; s < subdivisions; ++s) {
    std::map<std::pair<int, int>, int> midpoints;
    auto midpoint = [&](int a, int b) {
      const std::pair<int, int> key(std::min(a, b), std::max(a, b));
      auto it = midpoints.find(key);
      if (it != midpoints.end()) return it->second;
      points.push_back((points[a] + points[b]).normalized());
      const int index = static_cast<int>(points.size()) - 1;
      midpoints[key] = index;
      return index;
    };
    std::vector<Eigen::Vector3i> refined;
    for (const Eigen::Vector3i& f : faces) {
      const int ab = midpoint(f(0), f(1)), bc = midpoint(f(1), f(2)), ca = midpoint(f(2), f(0));
      refined.push_back({f(0), ab, ca});
      refined.push_back({f(1), bc, ab});
      refined.push_back({f(2), ca, bc});
      refined.push_back({ab, bc, ca});
    }
    faces.swap(refined);
  }
  SurfaceMesh sphere;
  sphere.vertices.resize(3, static_cast<Eigen::Index>(points.size()));
  for (size_t v = 0; v < points.size(); ++v) sphere.vertices.col(v) = centre + radius * points[v];
  sphere.triangles.resize(3, static_cast<Eigen::Index>(faces.size()));
  for (size_t t = 0; t < faces.size(); ++t) sphere.triangles.col(t) = faces[t];
  return sphere;
}

Eigen::Matrix3Xi RemoveTriangles(const Eigen::Matrix3Xi& triangles,
                                 const std::vector<int>& removed) {
  std::vector<char> drop(triangles.cols(), 0);
  for (int t : removed) drop[t] = 1;
  Eigen::Matrix3Xi result(3, triangles.cols() - static_cast<Eigen::Index>(removed.size()));
  int k = 0;
  for (int t = 0; t < triangles.cols(); ++t) {
    if (!drop[t]) result.col(k++) = triangles.col(t);
  }
  return result;
}

double EnclosedVolume(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles) {
  double volume = 0;
  for (int t = 0; t < triangles.cols(); ++t) {
    const Eigen::Vector3d x0 = vertices.col(triangles(0, t));
    const Eigen::Vector3d x1 = vertices.col(triangles(1, t));
    const Eigen::Vector3d x2 = vertices.col(triangles(2, t));
    volume += x0.dot((x1 - x0).cross(x2 - x0)) / 6.0;
  }
  return volume;
}

}  // namespace testing
}  // namespace aqs
