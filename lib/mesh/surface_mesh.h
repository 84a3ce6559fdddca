#ifndef AQS_MESH_SURFACE_MESH_H_
#define AQS_MESH_SURFACE_MESH_H_

#include <vector>

#include <Eigen/Core>

namespace aqs {

// A polygonal surface, kept both as its original polygons (for writing it back with
// the same faces) and as triangles (for computing).
//   vertices:        3 x num_vertices;
//   triangles:       3 x num_triangles, 0-based; polygons are fan-triangulated;
//   face_offsets:    polygon p has vertices face_vertices[face_offsets[p] ..
//                    face_offsets[p + 1]); size num_polygons + 1 (or empty when the
//                    surface is made of `triangles` only);
//   triangle_face:   index of the polygon each triangle comes from (empty if no
//                    polygons are stored).
struct SurfaceMesh {
  Eigen::Matrix3Xd vertices;
  Eigen::Matrix3Xi triangles;
  std::vector<int> face_offsets;
  std::vector<int> face_vertices;
  std::vector<int> triangle_face;

  int num_vertices() const { return static_cast<int>(vertices.cols()); }
  int num_triangles() const { return static_cast<int>(triangles.cols()); }
  int num_polygons() const {
    return face_offsets.empty() ? num_triangles() : static_cast<int>(face_offsets.size()) - 1;
  }
};

}  // namespace aqs

#endif  // AQS_MESH_SURFACE_MESH_H_
