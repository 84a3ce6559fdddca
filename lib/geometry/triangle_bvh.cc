#include "geometry/triangle_bvh.h"

#include <glog/logging.h>

#include <algorithm>
#include <cmath>

#include "util/parallel_for.h"

namespace aqs {
namespace {

// A triangle counts as degenerate when |ab x ac|^2 <= kDegenerate * (longest edge)^4,
// i.e. when the sine of its largest angle is below about 1e-8: the face formulas
// would divide by a vanishing area, and its edges are then within 1e-8 of its face.
constexpr double kDegenerate = 1e-16;

constexpr int kLeafSize = 4;

// The point of the segment [a, b] closest to p; *t is its parameter (a + t (b - a)).
Eigen::Vector3d ClosestPointOnSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                      const Eigen::Vector3d& b, double* t) {
  const Eigen::Vector3d ab = b - a;
  const double length_squared = ab.squaredNorm();
  double s = 0;
  if (length_squared > 0) s = std::clamp((p - a).dot(ab) / length_squared, 0.0, 1.0);
  *t = s;
  return a + s * ab;
}

// Squared distance from p to the box (0 inside).
double SquaredDistanceToBox(const Eigen::AlignedBox3d& box, const Eigen::Vector3d& p) {
  return box.squaredExteriorDistance(p);
}

}  // namespace

Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                                       const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                                       Eigen::Vector3d* barycentric) {
  Eigen::Vector3d weights;
  Eigen::Vector3d closest;
  const Eigen::Vector3d ab = b - a;
  const Eigen::Vector3d ac = c - a;
  const double longest_squared =
      std::max({ab.squaredNorm(), ac.squaredNorm(), (c - b).squaredNorm()});
  if (ab.cross(ac).squaredNorm() <= kDegenerate * longest_squared * longest_squared) {
    // Degenerate: the closest of the closest points on the three edges.
    double t;
    closest = ClosestPointOnSegment(p, a, b, &t);
    double best = (p - closest).squaredNorm();
    weights << 1 - t, t, 0;
    const Eigen::Vector3d on_bc = ClosestPointOnSegment(p, b, c, &t);
    if ((p - on_bc).squaredNorm() < best) {
      best = (p - on_bc).squaredNorm();
      closest = on_bc;
      weights << 0, 1 - t, t;
    }
    const Eigen::Vector3d on_ca = ClosestPointOnSegment(p, c, a, &t);
    if ((p - on_ca).squaredNorm() < best) {
      closest = on_ca;
      weights << t, 0, 1 - t;
    }
    if (barycentric != nullptr) *barycentric = weights;
    return closest;
  }

  const Eigen::Vector3d ap = p - a;
  const double d1 = ab.dot(ap);
  const double d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) {
    weights << 1, 0, 0;  // vertex region a
  } else {
    const Eigen::Vector3d bp = p - b;
    const double d3 = ab.dot(bp);
    const double d4 = ac.dot(bp);
    const Eigen::Vector3d cp = p - c;
    const double d5 = ab.dot(cp);
    const double d6 = ac.dot(cp);
    const double vc = d1 * d4 - d3 * d2;
    const double vb = d5 * d2 - d1 * d6;
    const double va = d3 * d6 - d5 * d4;
    if (d3 >= 0 && d4 <= d3) {
      weights << 0, 1, 0;  // vertex region b
    } else if (vc <= 0 && d1 >= 0 && d3 <= 0) {
      const double v = d1 / (d1 - d3);  // edge ab
      weights << 1 - v, v, 0;
    } else if (d6 >= 0 && d5 <= d6) {
      weights << 0, 0, 1;  // vertex region c
    } else if (vb <= 0 && d2 >= 0 && d6 <= 0) {
      const double w = d2 / (d2 - d6);  // edge ac
      weights << 1 - w, 0, w;
    } else if (va <= 0 && d4 - d3 >= 0 && d5 - d6 >= 0) {
      const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));  // edge bc
      weights << 0, 1 - w, w;
    } else {
      const double denominator = 1.0 / (va + vb + vc);  // face
      const double v = vb * denominator;
      const double w = vc * denominator;
      weights << 1 - v - w, v, w;
    }
  }
  closest = weights(0) * a + weights(1) * b + weights(2) * c;
  if (barycentric != nullptr) *barycentric = weights;
  return closest;
}

TriangleBvh::TriangleBvh(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles)
    : vertices_(vertices),
      triangles_(triangles),
      tree_(geometry_internal::BuildTriangleTree(vertices, triangles, kLeafSize)) {}

ClosestPointResult TriangleBvh::ClosestPoint(const Eigen::Vector3d& point,
                                             double max_distance) const {
  ClosestPointResult result;
  if (tree_.nodes.empty() || !(max_distance >= 0)) return result;
  // Squared distance a candidate must beat (or equal, before anything is found).
  double best = max_distance * max_distance;
  bool found = false;
  // Depth is O(log M); 128 entries cover any tree this build makes.
  int stack[128];
  int size = 0;
  stack[size++] = 0;
  while (size > 0) {
    const geometry_internal::TriangleTreeNode& node = tree_.nodes[stack[--size]];
    const double node_distance = SquaredDistanceToBox(node.box, point);
    if (found ? node_distance >= best : node_distance > best) continue;
    if (node.is_leaf()) {
      for (int i = node.begin; i < node.end; ++i) {
        const int t = tree_.order[i];
        Eigen::Vector3d weights;
        const Eigen::Vector3d closest = ClosestPointOnTriangle(
            point, vertices_.col(triangles_(0, t)), vertices_.col(triangles_(1, t)),
            vertices_.col(triangles_(2, t)), &weights);
        const double distance = (closest - point).squaredNorm();
        if (found ? distance < best : distance <= best) {
          best = distance;
          found = true;
          result.triangle = t;
          result.point = closest;
          result.barycentric = weights;
        }
      }
      continue;
    }
    // Visit the nearer child first (pushed last).
    const double left = SquaredDistanceToBox(tree_.nodes[node.left].box, point);
    const double right = SquaredDistanceToBox(tree_.nodes[node.right].box, point);
    CHECK_LE(size + 2, 128) << "tree too deep";
    if (left <= right) {
      stack[size++] = node.right;
      stack[size++] = node.left;
    } else {
      stack[size++] = node.left;
      stack[size++] = node.right;
    }
  }
  if (found) result.distance = std::sqrt(best);
  return result;
}

void TriangleBvh::TrianglesWithin(const Eigen::Vector3d& point, double radius,
                                  std::vector<int>* triangles) const {
  triangles->clear();
  if (tree_.nodes.empty() || !(radius > 0)) return;
  const double reach = radius * radius;
  int stack[128];
  int size = 0;
  stack[size++] = 0;
  while (size > 0) {
    const geometry_internal::TriangleTreeNode& node = tree_.nodes[stack[--size]];
    if (SquaredDistanceToBox(node.box, point) >= reach) continue;
    if (node.is_leaf()) {
      for (int i = node.begin; i < node.end; ++i) {
        const int t = tree_.order[i];
        const Eigen::Vector3d closest = ClosestPointOnTriangle(
            point, vertices_.col(triangles_(0, t)), vertices_.col(triangles_(1, t)),
            vertices_.col(triangles_(2, t)), nullptr);
        if ((closest - point).squaredNorm() < reach) triangles->push_back(t);
      }
      continue;
    }
    CHECK_LE(size + 2, 128) << "tree too deep";
    stack[size++] = node.right;
    stack[size++] = node.left;
  }
  std::sort(triangles->begin(), triangles->end());
}

std::vector<ClosestPointResult> TriangleBvh::ClosestPoints(const Eigen::Matrix3Xd& points,
                                                           int num_threads,
                                                           double max_distance) const {
  std::vector<ClosestPointResult> results(points.cols());
  ParallelFor(
      num_threads, 0, static_cast<int>(points.cols()),
      [&](int, int i) { results[i] = ClosestPoint(points.col(i), max_distance); }, 64);
  return results;
}

}  // namespace aqs
