#include "mesh/mesh_measures.h"

#include <Eigen/Geometry>

namespace aqs {

double MeanEdgeLength(const TetMesh& mesh) {
  if (mesh.num_tets() == 0) return 0.0;
  static const int kEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  double sum = 0.0;
  for (int e = 0; e < mesh.num_tets(); ++e) {
    for (const auto& edge : kEdges) {
      sum += (mesh.vertices.col(mesh.tets(edge[0], e)) - mesh.vertices.col(mesh.tets(edge[1], e)))
                 .norm();
    }
  }
  return sum / (6.0 * mesh.num_tets());
}

Eigen::VectorXd VertexAreas(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles) {
  Eigen::VectorXd areas = Eigen::VectorXd::Zero(vertices.cols());
  for (Eigen::Index t = 0; t < triangles.cols(); ++t) {
    const Eigen::Vector3d a = vertices.col(triangles(0, t));
    const double area =
        0.5 * (vertices.col(triangles(1, t)) - a).cross(vertices.col(triangles(2, t)) - a).norm();
    for (int k = 0; k < 3; ++k) areas[triangles(k, t)] += area / 3.0;
  }
  return areas;
}

}  // namespace aqs
