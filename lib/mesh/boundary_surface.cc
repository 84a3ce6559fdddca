#include "mesh/boundary_surface.h"

#include <glog/logging.h>

#include "mesh/tet_faces.h"

namespace aqs {

BoundarySurface ExtractBoundarySurface(const TetMesh& mesh) {
  const int num_vertices = mesh.num_vertices();
  const int num_tets = mesh.num_tets();
  const mesh_internal::TetFaceTable table = mesh_internal::BuildTetFaceTable(mesh);

  // A face is on the boundary if no other element has the same triangle.
  std::vector<char> is_boundary(static_cast<size_t>(num_tets) * 4, 0);
  int num_boundary = 0;
  for (int a = 0; a < num_vertices; ++a) {
    const int end = table.offsets[a + 1];
    for (int begin = table.offsets[a]; begin < end;) {
      int stop = begin + 1;
      while (stop < end && table.faces[stop].b == table.faces[begin].b &&
             table.faces[stop].c == table.faces[begin].c) {
        ++stop;
      }
      if (stop - begin == 1) {
        const mesh_internal::TetFace& face = table.faces[begin];
        is_boundary[static_cast<size_t>(face.tet) * 4 + face.local] = 1;
        ++num_boundary;
      }
      begin = stop;
    }
  }

  BoundarySurface boundary;
  boundary.triangles.resize(3, num_boundary);
  boundary.triangle_tet.resize(num_boundary);
  std::vector<char> on_boundary(num_vertices, 0);
  int k = 0;
  for (int t = 0; t < num_tets; ++t) {
    bool negative = false;
    bool computed = false;
    for (int f = 0; f < 4; ++f) {
      if (!is_boundary[static_cast<size_t>(t) * 4 + f]) continue;
      if (!computed) {
        negative = SignedTetVolume(mesh, mesh.vertices, t) < 0;
        computed = true;
      }
      const int* local = mesh_internal::kOutwardFace[f];
      int v0 = mesh.tets(local[0], t), v1 = mesh.tets(local[1], t), v2 = mesh.tets(local[2], t);
      if (negative) std::swap(v1, v2);
      boundary.triangles.col(k) << v0, v1, v2;
      boundary.triangle_tet[k] = t;
      on_boundary[v0] = on_boundary[v1] = on_boundary[v2] = 1;
      ++k;
    }
  }
  for (int v = 0; v < num_vertices; ++v) {
    if (on_boundary[v]) boundary.vertices.push_back(v);
  }
  return boundary;
}

SurfaceMesh BoundaryToSurface(const BoundarySurface& boundary, const Eigen::Matrix3Xd& positions) {
  const int num_positions = static_cast<int>(positions.cols());
  std::vector<int> surface_index(num_positions, -1);
  SurfaceMesh surface;
  surface.vertices.resize(3, static_cast<Eigen::Index>(boundary.vertices.size()));
  for (size_t i = 0; i < boundary.vertices.size(); ++i) {
    const int v = boundary.vertices[i];
    CHECK(v >= 0 && v < num_positions)
        << "boundary vertex " << v << " has no position (" << num_positions << " given)";
    surface_index[v] = static_cast<int>(i);
    surface.vertices.col(static_cast<Eigen::Index>(i)) = positions.col(v);
  }
  surface.triangles.resize(3, boundary.triangles.cols());
  for (Eigen::Index t = 0; t < boundary.triangles.cols(); ++t) {
    for (int i = 0; i < 3; ++i) {
      const int v = boundary.triangles(i, t);
      CHECK(v >= 0 && v < num_positions && surface_index[v] >= 0)
          << "boundary triangle " << t << " uses vertex " << v
          << " which is not in boundary.vertices";
      surface.triangles(i, t) = surface_index[v];
    }
  }
  return surface;
}

}  // namespace aqs
