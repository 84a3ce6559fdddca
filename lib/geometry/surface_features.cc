#include "geometry/surface_features.h"

#include <algorithm>
#include <array>
#include <vector>

#include <glog/logging.h>

namespace aqs {

SurfaceFeatures BuildSurfaceFeatures(const Eigen::Matrix3Xi& triangles, int num_vertices) {
  const int m = static_cast<int>(triangles.cols());
  // (smaller vertex, larger vertex, slot 3 t + k) for every side k of every triangle t.
  std::vector<std::array<int, 3>> sides;
  sides.reserve(3 * static_cast<size_t>(m));
  for (int t = 0; t < m; ++t) {
    for (int k = 0; k < 3; ++k) {
      const int a = triangles(k, t), b = triangles((k + 1) % 3, t);
      CHECK(a >= 0 && a < num_vertices && b >= 0 && b < num_vertices)
          << "triangle " << t << " has a vertex out of range";
      sides.push_back({std::min(a, b), std::max(a, b), 3 * t + k});
    }
  }
  std::sort(sides.begin(), sides.end());
  SurfaceFeatures features;
  features.triangle_edges.resize(3, m);
  std::vector<std::array<int, 2>> edges;
  std::vector<int> faces_at_edge;
  for (size_t i = 0; i < sides.size(); ++i) {
    if (i == 0 || sides[i][0] != sides[i - 1][0] || sides[i][1] != sides[i - 1][1]) {
      edges.push_back({sides[i][0], sides[i][1]});
      faces_at_edge.push_back(0);
    }
    ++faces_at_edge.back();
    features.triangle_edges(sides[i][2] % 3, sides[i][2] / 3) = static_cast<int>(edges.size()) - 1;
  }
  const int e = static_cast<int>(edges.size());
  features.edges.resize(2, e);
  features.edge_weights.resize(e);
  // w_v = 1 + faces - edges at v, for vertices of some triangle.
  std::vector<int> faces_at_vertex(num_vertices, 0), edges_at_vertex(num_vertices, 0);
  for (int t = 0; t < m; ++t) {
    for (int k = 0; k < 3; ++k) ++faces_at_vertex[triangles(k, t)];
  }
  for (int i = 0; i < e; ++i) {
    features.edges.col(i) << edges[i][0], edges[i][1];
    features.edge_weights[i] = 1.0 - faces_at_edge[i];
    ++edges_at_vertex[edges[i][0]];
    ++edges_at_vertex[edges[i][1]];
  }
  features.vertex_weights.resize(num_vertices);
  for (int v = 0; v < num_vertices; ++v) {
    features.vertex_weights[v] =
        faces_at_vertex[v] == 0 ? 0.0 : 1.0 + faces_at_vertex[v] - edges_at_vertex[v];
  }
  return features;
}

}  // namespace aqs
