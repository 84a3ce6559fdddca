#ifndef AQS_MESH_MESH_MEASURES_H_
#define AQS_MESH_MESH_MEASURES_H_

#include <Eigen/Core>

#include "mesh/tet_mesh.h"

namespace aqs {

// The mean over elements of the mean of their six edge lengths (0 for no elements); a
// Kuhn lattice of cube edge c has 1.26 c.
double MeanEdgeLength(const TetMesh& mesh);

// Each surface vertex's share of the surface area: a third of each incident triangle's
// area (vertices: 3 x N; triangles: 3 x M). N values.
Eigen::VectorXd VertexAreas(const Eigen::Matrix3Xd& vertices, const Eigen::Matrix3Xi& triangles);

}  // namespace aqs

#endif  // AQS_MESH_MESH_MEASURES_H_
