#ifndef AQS_GEOMETRY_WINDING_NUMBER_H_
#define AQS_GEOMETRY_WINDING_NUMBER_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/triangle_tree.h"

namespace aqs {

// Generalized winding number of a triangle soup (Jacobson, Kavan and Sorkine-Hornung,
// "Robust inside-outside segmentation using generalized winding numbers", 2013):
// w(q) = sum over triangles of the signed solid angle the triangle subtends at q, over
// 4 pi. For a closed, consistently oriented surface with outward normals (right-hand
// rule on the vertex order) w is 1 inside and 0 outside; for a surface with holes it
// varies smoothly in between, about 1/2 across a hole, which is what makes it a robust
// inside test for open surfaces. Points on the surface itself get the mean of the values
// on both sides (each triangle containing the point contributes 0).
//
// Every function takes the surface as
//   vertices:  3 x N, column v is vertex v (finite);
//   triangles: 3 x M, 0-based vertex indices, each in [0, N) (CHECK).

// Signed solid angle of the triangle (a, b, c) seen from p, in [-2 pi, 2 pi]
// (Van Oosterom and Strackee's formula, tan(omega / 2) = det[a b c] / (|a||b||c| +
// (a.b)|c| + (a.c)|b| + (b.c)|a|) with a, b, c relative to p): positive when p is
// on the side opposite the triangle's right-hand normal. 0 for p in the triangle's
// plane and for a degenerate triangle.
double TriangleSolidAngle(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                          const Eigen::Vector3d& b, const Eigen::Vector3d& c);

// The exact winding number at `point`: the direct sum over all triangles, O(M).
double ExactWindingNumber(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                          const Eigen::Vector3d& point);

// ExactWindingNumber at every column of `points` (3 x K) on up to num_threads
// threads; K values in column order. O(K M): a reference for FastWindingNumber.
Eigen::VectorXd ExactWindingNumbers(const Eigen::Matrix3Xd& vertices,
                                    const Eigen::Matrix3Xi& triangles,
                                    const Eigen::Matrix3Xd& points, int num_threads);

struct FastWindingNumberOptions {
  // A tree node's far-field expansion replaces its exact sum when the query is farther
  // than beta times the node's radius from the node's centre (Barill et al. use 2).
  double beta = 2.0;
  // Terms of the far-field expansion: 0 keeps only the dipole term (the area-weighted
  // normal sum at the node centre), 1 adds the first-order term, 2 the second-order
  // term (Barill et al.'s choice). Higher orders are more accurate at the same beta.
  int expansion_order = 2;
  // Largest number of triangles in a leaf (summed exactly when near).
  int leaf_size = 8;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// Hierarchical winding numbers (Barill, Dickson, Schmidt, Levin and Jacobson, "Fast
// winding numbers for soups and clouds", 2018). A tree over the triangles (median
// splits, geometry_internal::BuildTriangleTree) stores at every node a Taylor expansion
// of the node's dipole field about the node's area-weighted centroid p~:
//   order 0: N     = sum_t A_t n_t,
//   order 1: M_ij  = sum_t A_t n_t,i (c_t - p~)_j                  (c_t: centroid),
//   order 2: T_ijk = sum_t n_t,i integral_t (x - p~)_j (x - p~)_k dA  (exact),
// where n_t is the unit normal and A_t the area of triangle t. A query farther than
// beta * radius from p~ (radius: largest distance from p~ to a vertex of the node) uses
// the expansion; otherwise the node's children are visited, and leaves are summed
// exactly. Accuracy (largest / mean absolute error against ExactWindingNumbers, measured
// in the tests and on the ICT face): beta 2, order 2 (the defaults): ~5e-3 / ~1e-3;
// beta 3: ~1e-3 / ~2e-4 at about 2.5 times the cost; orders 0 and 1: ~5e-2 / ~5e-3 at
// beta 2. The error hardly depends on the query's distance to the surface (it comes from
// the nodes just beyond beta * radius of the query, at every scale) and is small against
// the 1/2 an inside test compares with.
// Built once in O(M log M), then queried from any number of threads; copies the surface.
class FastWindingNumber {
 public:
  FastWindingNumber(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                    const FastWindingNumberOptions& options = FastWindingNumberOptions());

  int num_triangles() const { return static_cast<int>(triangles_.cols()); }

  // The winding number at `point` (0 for a surface without triangles).
  double WindingNumber(const Eigen::Vector3d& point) const;

  // WindingNumber at every column of `points` (3 x K) on up to num_threads threads;
  // K values in column order, independent of the thread count.
  Eigen::VectorXd WindingNumbers(const Eigen::Matrix3Xd& points, int num_threads) const;

 private:
  // Far-field data of one tree node (see the class comment).
  struct Expansion {
    Eigen::Vector3d centre;
    double radius = 0;
    Eigen::Vector3d n;
    Eigen::Matrix3d m;
    Eigen::Matrix3d t[3];  // t[i](j, k) = T_ijk
  };

  double FarField(const Expansion& expansion, const Eigen::Vector3d& point) const;

  FastWindingNumberOptions options_;
  Eigen::Matrix3Xd vertices_;
  Eigen::Matrix3Xi triangles_;
  geometry_internal::TriangleTree tree_;
  std::vector<Expansion> expansions_;  // one per tree node
};

}  // namespace aqs

#endif  // AQS_GEOMETRY_WINDING_NUMBER_H_
