#include "geometry/triangle_tree.h"

#include <glog/logging.h>

#include <algorithm>

namespace aqs {
namespace geometry_internal {

TriangleTree BuildTriangleTree(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles,
                               int leaf_size) {
  CHECK_GE(leaf_size, 1);
  const int num_vertices = static_cast<int>(vertices.cols());
  const int num_triangles = static_cast<int>(triangles.cols());
  TriangleTree tree;
  if (num_triangles == 0) return tree;

  std::vector<Eigen::AlignedBox3d> boxes(num_triangles);
  Eigen::Matrix3Xd centroids(3, num_triangles);
  for (int t = 0; t < num_triangles; ++t) {
    Eigen::AlignedBox3d box;
    for (int k = 0; k < 3; ++k) {
      const int v = triangles(k, t);
      CHECK(v >= 0 && v < num_vertices) << "triangle " << t << " has vertex index " << v
                                        << " out of range [0, " << num_vertices << ")";
      box.extend(vertices.col(v));
    }
    boxes[t] = box;
    centroids.col(t) = (vertices.col(triangles(0, t)) + vertices.col(triangles(1, t)) +
                        vertices.col(triangles(2, t))) /
                       3.0;
  }
  tree.order.resize(num_triangles);
  for (int t = 0; t < num_triangles; ++t) tree.order[t] = t;
  tree.nodes.reserve(2 * (num_triangles / leaf_size + 1));

  // Nodes are split in creation order, so children always follow their parent.
  TriangleTreeNode root;
  root.begin = 0;
  root.end = num_triangles;
  tree.nodes.push_back(root);
  for (size_t n = 0; n < tree.nodes.size(); ++n) {
    const int begin = tree.nodes[n].begin;
    const int end = tree.nodes[n].end;
    Eigen::AlignedBox3d box;
    Eigen::AlignedBox3d centroid_box;
    for (int i = begin; i < end; ++i) {
      box.extend(boxes[tree.order[i]]);
      centroid_box.extend(Eigen::Vector3d(centroids.col(tree.order[i])));
    }
    tree.nodes[n].box = box;
    if (end - begin <= leaf_size) continue;
    int axis;
    const double extent = centroid_box.sizes().maxCoeff(&axis);
    if (!(extent > 0)) continue;  // all centroids coincide: no split separates them
    const int middle = begin + (end - begin) / 2;
    std::nth_element(tree.order.begin() + begin, tree.order.begin() + middle,
                     tree.order.begin() + end, [&centroids, axis](int a, int b) {
                       const double ca = centroids(axis, a), cb = centroids(axis, b);
                       return ca < cb || (ca == cb && a < b);
                     });
    TriangleTreeNode left, right;
    left.begin = begin;
    left.end = middle;
    right.begin = middle;
    right.end = end;
    tree.nodes[n].left = static_cast<int>(tree.nodes.size());
    tree.nodes[n].right = tree.nodes[n].left + 1;
    tree.nodes.push_back(left);
    tree.nodes.push_back(right);
  }
  return tree;
}

}  // namespace geometry_internal
}  // namespace aqs
