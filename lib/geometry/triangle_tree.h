#ifndef AQS_GEOMETRY_TRIANGLE_TREE_H_
#define AQS_GEOMETRY_TRIANGLE_TREE_H_

// Internal: the binary tree over the triangles of a surface that TriangleBvh (closest
// points) and FastWindingNumber (hierarchical winding numbers) are built on. Not part of
// the public API.

#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace aqs {
namespace geometry_internal {

// One node: a contiguous range of the tree's triangle order and the bounding box of
// those triangles. A leaf has no children; an inner node has exactly two, whose
// ranges split its own range (left first).
struct TriangleTreeNode {
  Eigen::AlignedBox3d box;
  int begin = 0;  // the node's triangles are order[begin .. end)
  int end = 0;
  int left = -1;  // child node indices, both -1 for a leaf
  int right = -1;

  bool is_leaf() const { return left < 0; }
};

// nodes[0] is the root (no nodes when there are no triangles); a child always has a
// larger index than its parent. order is a permutation of the triangle indices.
struct TriangleTree {
  std::vector<TriangleTreeNode> nodes;
  std::vector<int> order;
};

// Top-down build: a node's triangles are split at the median of their centroids along
// the longest axis of the centroids' bounding box, until at most `leaf_size`
// triangles remain (or all centroids coincide). vertices: 3 x N; triangles: 3 x M,
// every index in [0, N) (CHECK). O(M log M); depth O(log M).
TriangleTree BuildTriangleTree(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                               int leaf_size);

}  // namespace geometry_internal
}  // namespace aqs

#endif  // AQS_GEOMETRY_TRIANGLE_TREE_H_
