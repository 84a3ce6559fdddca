#ifndef AQS_GEOMETRY_TRIANGLE_INTERSECTIONS_H_
#define AQS_GEOMETRY_TRIANGLE_INTERSECTIONS_H_

#include <utility>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// Whether the closed triangles (a0, a1, a2) and (b0, b1, b2) share at least one point.
// Touching counts: a common vertex, a vertex on the other triangle's edge or face, an
// edge crossing an edge, or coplanar triangles that only share boundary points all
// intersect. The vertex order (orientation) of either triangle does not matter, and
// swapping the two triangles gives the same answer.
//
// The test is Guigue and Devillers' ("Fast and robust triangle-triangle overlap test
// using orientation predicates", 2003): the signs of orientation determinants
// det[b - a, c - a, d - a] first reject triangles that lie on one side of the other's
// plane, then compare the two segments in which the triangles cut the line common to
// both planes without computing that line. Coplanar triangles (every vertex of one on
// the other's plane) are compared in 2D, in the coordinate plane onto which their plane
// projects one-to-one: they intersect when an edge of one meets an edge of the other or
// a vertex of one lies in the other.
//
// The orientation signs are exact: each determinant is evaluated in floating point
// with an error bound, and again in exact (expansion) arithmetic when the bound does
// not settle its sign (Shewchuk, "Adaptive precision floating-point arithmetic and fast
// robust geometric predicates", 1997). The answer is therefore the exact answer for the
// given double coordinates, in general position and in every degenerate one (touching,
// coplanar, parallel), and it is consistent under reordering. Only coordinate
// differences so small that products of three of them underflow (below about 1e-95)
// can make it inexact.
//
// Degenerate triangles (collinear or coincident corners, decided exactly) are treated
// as the point set they are: the segment between their two extreme corners, or a single
// point. So a zero-area triangle lying across a face intersects it, and two degenerate
// triangles intersect when their segments (or points) meet.
bool TrianglesIntersect(const Eigen::Vector3d& a0, const Eigen::Vector3d& a1,
                        const Eigen::Vector3d& a2, const Eigen::Vector3d& b0,
                        const Eigen::Vector3d& b1, const Eigen::Vector3d& b2);

struct TriangleIntersectionOptions {
  // Pairs of triangles sharing a vertex index never count (they always touch there).
  // This also hides real folds between neighbours, e.g. two triangles sharing an edge
  // that overlap in a coplanar fold; with false, every such pair is reported.
  bool skip_adjacent = true;
  int num_threads = 2;
};

// The pairs of triangles of one surface that intersect (TrianglesIntersect), i.e. its
// self-intersections:
//   vertices:  3 x N, column v is vertex v (finite);
//   triangles: 3 x M, 0-based vertex indices, each in [0, N) (CHECK);
//   pairs:     (may be null) set to the pairs (i, j), i < j, sorted lexicographically.
// Returns the number of pairs. A pair is tested exactly when the bounding boxes of its
// triangles touch, found by one query per triangle in a bounding-box tree over the
// triangles (geometry_internal::BuildTriangleTree, median splits): O(M log M + pairs
// of touching boxes). The triangles are divided among up to options.num_threads
// threads; the result does not depend on the thread count.
int FindIntersectingTrianglePairs(const Eigen::Matrix3Xd& vertices,
                                  const Eigen::Matrix3Xi& triangles,
                                  const TriangleIntersectionOptions& options,
                                  std::vector<std::pair<int, int>>* pairs);

// The pairs of triangles, one from surface a and one from surface b, that intersect
// (e.g. a surface against an obstacle). Each surface as above (3 x N_a vertices and
// 3 x M_a triangles, 3 x N_b and 3 x M_b; indices in range, CHECK). pairs (may be null)
// is set to the pairs (i, j), i a column of triangles_a and j one of triangles_b,
// sorted lexicographically. Returns the number of pairs. The tree is built over b and
// queried with every triangle of a on up to num_threads threads; the result does not
// depend on the thread count.
int FindIntersectingTrianglePairs(const Eigen::Matrix3Xd& vertices_a,
                                  const Eigen::Matrix3Xi& triangles_a,
                                  const Eigen::Matrix3Xd& vertices_b,
                                  const Eigen::Matrix3Xi& triangles_b, int num_threads,
                                  std::vector<std::pair<int, int>>* pairs);

}  // namespace aqs

#endif  // AQS_GEOMETRY_TRIANGLE_INTERSECTIONS_H_
