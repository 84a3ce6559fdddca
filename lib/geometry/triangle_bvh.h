#ifndef AQS_GEOMETRY_TRIANGLE_BVH_H_
#define AQS_GEOMETRY_TRIANGLE_BVH_H_

#include <limits>
#include <vector>

#include <Eigen/Core>

#include "geometry/triangle_tree.h"

namespace aqs {

// The point of a triangle surface closest to a query point.
//   distance:    Euclidean distance from the query to `point` (infinity when nothing
//                was found: no triangles, or none within the search radius);
//   triangle:    index of the triangle (column of the triangle matrix) holding `point`,
//                -1 when nothing was found;
//   point:       the closest point;
//   barycentric: its weights in that triangle: point = sum_k barycentric(k) *
//                vertices.col(triangles(k, triangle)); non-negative, summing to 1.
struct ClosestPointResult {
  double distance = std::numeric_limits<double>::infinity();
  int triangle = -1;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d barycentric = Eigen::Vector3d::Zero();
};

// The point of the triangle (a, b, c) closest to p, exactly (Voronoi regions of the
// vertices, edges and face; Ericson, Real-Time Collision Detection, 5.1.5), and its
// barycentric weights in (a, b, c) in *barycentric (may be null). A degenerate triangle
// (zero or nearly zero area: collinear or coincident corners) is treated as the union
// of its three edges, so the answer is still the closest point of the point set.
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                       Eigen::Vector3d* barycentric);

// Axis-aligned bounding-box tree over the triangles of a surface, for closest-point
// queries. Built once (O(M log M)), then queried from any number of threads.
//   vertices:  3 x N, column v is vertex v (finite);
//   triangles: 3 x M, 0-based vertex indices, each in [0, N) (CHECK).
// Copies the surface. Leaves hold up to 4 triangles.
class TriangleBvh {
 public:
  TriangleBvh(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles);

  int num_triangles() const { return static_cast<int>(triangles_.cols()); }
  const Eigen::Matrix3Xd& vertices() const { return vertices_; }
  const Eigen::Matrix3Xi& triangles() const { return triangles_; }

  // The closest point of the surface to `point` among those at distance <=
  // max_distance (nodes farther away are never visited, so a small radius is fast);
  // triangle == -1 if there is none. Of several triangles at the same distance, the
  // first one the deterministic traversal meets is reported.
  ClosestPointResult ClosestPoint(
      const Eigen::Vector3d& point,
      double max_distance = std::numeric_limits<double>::infinity()) const;

  // The triangles whose closest point to `point` is nearer than `radius` (strictly),
  // in ascending index order, in *triangles (cleared first); none for a radius <= 0.
  void TrianglesWithin(const Eigen::Vector3d& point, double radius,
                       std::vector<int>* triangles) const;

  // ClosestPoint for every column of `points` (3 x K) on up to num_threads threads;
  // result i belongs to column i. The results do not depend on the thread count.
  std::vector<ClosestPointResult> ClosestPoints(
      const Eigen::Matrix3Xd& points, int num_threads,
      double max_distance = std::numeric_limits<double>::infinity()) const;

 private:
  Eigen::Matrix3Xd vertices_;
  Eigen::Matrix3Xi triangles_;
  geometry_internal::TriangleTree tree_;
};

}  // namespace aqs

#endif  // AQS_GEOMETRY_TRIANGLE_BVH_H_
