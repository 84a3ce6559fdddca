#include "geometry/vertex_normals.h"

#include <Eigen/Geometry>

namespace aqs {

Eigen::Matrix3Xd VertexNormals(const Eigen::Matrix3Xd& vertices,
                               const Eigen::Matrix3Xi& triangles) {
  Eigen::Matrix3Xd normals = Eigen::Matrix3Xd::Zero(3, vertices.cols());
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    const Eigen::Vector3d a = vertices.col(triangles(0, t));
    const Eigen::Vector3d n =
        (vertices.col(triangles(1, t)) - a).cross(vertices.col(triangles(2, t)) - a);
    for (int k = 0; k < 3; ++k) normals.col(triangles(k, t)) += n;
  }
  for (Eigen::Index v = 0; v < normals.cols(); ++v) {
    const double length = normals.col(v).norm();
    if (length > 0) normals.col(v) /= length;
  }
  return normals;
}

}  // namespace aqs
