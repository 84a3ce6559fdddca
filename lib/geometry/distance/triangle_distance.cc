#include "geometry/distance/triangle_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "geometry/triangle_bvh.h"

namespace aqs {

double SegmentSegmentDistance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                              const Eigen::Vector3d& q0, const Eigen::Vector3d& q1) {
  const Eigen::Vector3d d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  const double tiny = 1e-300;
  double s = 0.0, t = 0.0;
  if (a <= tiny && e <= tiny) return r.norm();
  if (a <= tiny) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= tiny) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      // Minimize |p0 + s d1 - q0 - t d2|^2 over the unit square: the line solution (or
      // s = 0 for parallel lines) clamped, then t for that s, then s again for a clamped t.
      const double b = d1.dot(d2), denominator = a * e - b * b;
      s = denominator > 1e-14 * a * e ? std::clamp((b * f - c * e) / denominator, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return (p0 + s * d1 - q0 - t * d2).norm();
}

double DisjointTriangleDistance(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  double best = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    best = std::min(best, (a.col(k) - ClosestPointOnTriangle(a.col(k), b.col(0), b.col(1),
                                                             b.col(2), nullptr)).norm());
    best = std::min(best, (b.col(k) - ClosestPointOnTriangle(b.col(k), a.col(0), a.col(1),
                                                             a.col(2), nullptr)).norm());
  }
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      best = std::min(best, SegmentSegmentDistance(a.col(i), a.col((i + 1) % 3), b.col(j),
                                                   b.col((j + 1) % 3)));
    }
  }
  return best;
}

}  // namespace aqs
