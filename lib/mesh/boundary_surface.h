#ifndef AQS_MESH_BOUNDARY_SURFACE_H_
#define AQS_MESH_BOUNDARY_SURFACE_H_

#include <vector>

#include <Eigen/Core>

#include "mesh/surface_mesh.h"
#include "mesh/tet_mesh.h"

namespace aqs {

// The boundary of a tet mesh: the triangles that belong to exactly one element,
// oriented so that their normal (right-hand rule on the vertex order) points out of
// that element at rest (whatever the sign convention of the element order).
//   triangles:      3 x num_triangles, indices into the tet mesh's vertices;
//   triangle_tet:   the element each triangle belongs to;
//   vertices:       sorted tet-mesh indices of the vertices on the boundary.
struct BoundarySurface {
  Eigen::Matrix3Xi triangles;
  std::vector<int> triangle_tet;
  std::vector<int> vertices;
};

// Triangles come in element order (element t's faces in the order of the vertex they
// are opposite to). The orientation of each triangle follows the sign of its own
// element's signed volume. Every index of `mesh` must be in range (CHECK); a triangle
// shared by three or more elements is not on the boundary. O(n log n) at most.
BoundarySurface ExtractBoundarySurface(const TetMesh& mesh);

// A standalone surface made of the boundary triangles with only the boundary
// vertices, renumbered in the order of boundary.vertices and placed at `positions`
// (3 x mesh.num_vertices(): rest or deformed). surface vertex i is tet-mesh vertex
// boundary.vertices[i].
SurfaceMesh BoundaryToSurface(const BoundarySurface& boundary,
                              const Eigen::Matrix3Xd& positions);

}  // namespace aqs

#endif  // AQS_MESH_BOUNDARY_SURFACE_H_
