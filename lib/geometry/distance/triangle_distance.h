#ifndef AQS_GEOMETRY_DISTANCE_TRIANGLE_DISTANCE_H_
#define AQS_GEOMETRY_DISTANCE_TRIANGLE_DISTANCE_H_

#include <Eigen/Core>

namespace aqs {

// The distance between the segments [p0, p1] and [q0, q1] (closest points by clamped
// line parameters; degenerate segments are points).
double SegmentSegmentDistance(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1,
                              const Eigen::Vector3d& q0, const Eigen::Vector3d& q1);

// The distance between two triangles (columns of a and b are their corners) when they
// do not intersect: the least of the 6 corner-to-triangle distances
// (ClosestPointOnTriangle) and the 9 edge-to-edge distances. For intersecting triangles
// the result is not 0 in general (test intersection separately).
double DisjointTriangleDistance(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

}  // namespace aqs

#endif  // AQS_GEOMETRY_DISTANCE_TRIANGLE_DISTANCE_H_
