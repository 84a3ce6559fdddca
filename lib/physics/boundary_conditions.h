#ifndef AQS_PHYSICS_BOUNDARY_CONDITIONS_H_
#define AQS_PHYSICS_BOUNDARY_CONDITIONS_H_

#include <string>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// Dirichlet boundary conditions: vertices whose position is prescribed.
//   vertices:   indices of the fixed vertices (distinct);
//   positions:  3 x vertices.size() prescribed positions, or empty to keep every fixed
//               vertex at its rest position. Bone-driven vertices are fixed vertices
//               whose positions the caller updates between solves.
struct BoundaryConditions {
  std::vector<int> vertices;
  Eigen::Matrix3Xd positions;
};

// Checks `bc` against a mesh with `num_vertices` vertices: indices in range and
// distinct, positions empty or 3 x vertices.size() and finite. Returns false with
// *error naming `source` and the first offending entry.
bool ValidateBoundaryConditions(const BoundaryConditions& bc, int num_vertices,
                                const std::string& source, std::string* error);

// A mask of num_vertices entries, true for the fixed ones.
std::vector<bool> FixedVertexMask(const BoundaryConditions& bc, int num_vertices);

}  // namespace aqs

#endif  // AQS_PHYSICS_BOUNDARY_CONDITIONS_H_
