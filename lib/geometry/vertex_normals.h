#ifndef AQS_GEOMETRY_VERTEX_NORMALS_H_
#define AQS_GEOMETRY_VERTEX_NORMALS_H_

#include <Eigen/Core>

namespace aqs {

// Area-weighted vertex normals of a triangle surface: for each vertex, the normalized
// sum of the cross products (b - a) x (c - a) of the triangles (a, b, c) around it, whose
// length is twice the triangle's area. vertices: 3 x num_vertices; triangles: 3 x
// num_triangles, counter-clockwise seen from outside for outward normals. Returns 3 x
// num_vertices, unit length; zero for a vertex in no triangle (or whose triangles' sum
// vanishes).
Eigen::Matrix3Xd VertexNormals(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles);

}  // namespace aqs

#endif  // AQS_GEOMETRY_VERTEX_NORMALS_H_
