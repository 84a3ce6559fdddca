#ifndef AQS_GEOMETRY_SURFACE_COMPONENTS_H_
#define AQS_GEOMETRY_SURFACE_COMPONENTS_H_

#include <vector>

#include <Eigen/Core>

namespace aqs {

// Connected components of a triangle surface, two triangles being connected when they
// share a vertex.
//   vertex_component:   num_vertices entries: the component of each vertex, -1 for a
//                       vertex no triangle uses;
//   triangle_component: num_triangles entries: the component of each triangle;
//   vertices:           per component, its vertex indices in increasing order.
// Components are numbered in the order of their smallest vertex index.
struct SurfaceComponents {
  std::vector<int> vertex_component;
  std::vector<int> triangle_component;
  std::vector<std::vector<int>> vertices;

  int num_components() const { return static_cast<int>(vertices.size()); }
};

// The components of the surface with `num_vertices` vertices and `triangles` (3 x M,
// 0-based indices in [0, num_vertices); CHECK). Union-find, near-linear time.
SurfaceComponents FindSurfaceComponents(int num_vertices, const Eigen::Matrix3Xi& triangles);

// One boundary loop: a sequence of vertices v_0 .. v_{n-1} whose consecutive pairs (and,
// when closed, the pair v_{n-1} v_0) are boundary edges, i.e. edges used by exactly one
// triangle. A closed loop has n edges, an open chain n - 1.
struct BoundaryLoop {
  std::vector<int> vertices;
  bool closed = true;

  int num_edges() const { return static_cast<int>(vertices.size()) - (closed ? 0 : 1); }
};

// The boundary loops of a surface (triangles: 3 x M, non-negative indices; CHECK),
// each boundary edge in exactly one loop. Loops follow the edge directions of their
// triangles (v_i -> v_{i+1} as in the triangle's vertex order) when the surface is
// consistently oriented; the walk crosses an edge against its direction only where the
// orientation is inconsistent. At a vertex with several boundary edges (holes touching
// at a vertex) the loop closes as soon as it returns to its start, so each loop is a
// simple cycle whenever possible. Chains that cannot close (boundary vertices of odd
// boundary degree, which only non-manifold edges produce) are returned with closed ==
// false. Loops start at their boundary edge that comes first in triangle order, and come
// in that order. Edges of degenerate triangles (a repeated vertex) are ignored.
std::vector<BoundaryLoop> FindBoundaryLoops(const Eigen::Matrix3Xi& triangles);

}  // namespace aqs

#endif  // AQS_GEOMETRY_SURFACE_COMPONENTS_H_
