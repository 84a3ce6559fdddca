#ifndef AQS_MESH_TET_MESH_H_
#define AQS_MESH_TET_MESH_H_

#include <string>

#include <Eigen/Core>

namespace aqs {

// A tetrahedral mesh.
//   vertices: 3 x num_vertices, column v is the position of vertex v (so the data
//             is x0 y0 z0 x1 y1 z1 ..., the layout the solvers use for states);
//   tets:     4 x num_tets, 0-based vertex indices of each element.
// Element orientation is not prescribed: a file may list all elements with positive
// or all with negative signed volume; what matters physically is F = Ds Dm^-1, which
// does not depend on the order of an element's vertices. Mixed signs mean some
// elements are inverted with respect to the rest, which ValidateTetMesh rejects.
struct TetMesh {
  Eigen::Matrix3Xd vertices;
  Eigen::Matrix4Xi tets;

  int num_vertices() const { return static_cast<int>(vertices.cols()); }
  int num_tets() const { return static_cast<int>(tets.cols()); }
};

// Signed volume det([x1 - x0, x2 - x0, x3 - x0]) / 6.
double SignedTetVolume(const Eigen::Vector3d& x0, const Eigen::Vector3d& x1,
                       const Eigen::Vector3d& x2, const Eigen::Vector3d& x3);

// Signed volume of element t of `mesh` at positions `positions` (3 x num_vertices).
double SignedTetVolume(const TetMesh& mesh, const Eigen::Matrix3Xd& positions, int t);

struct TetMeshValidationOptions {
  // An element is flat if 6 |V| <= flat_tolerance * (longest edge)^3. A regular
  // tetrahedron has 6 V / l^3 = 0.707.
  double flat_tolerance = 1e-10;
};

// Checks that `mesh` can be simulated: at least one element; every index in range;
// the four indices of an element distinct; no element flat; all elements with the
// same sign of signed volume (the sign of the majority; an element with the other
// sign is inverted); no triangle shared by more than two elements, nor by two on the
// same side of it (duplicated or overlapping elements). Finite coordinates. On failure
// returns false and *error names `source` (a file name or description), the first
// offending element (0-based index and its vertices) and what is wrong with it.
bool ValidateTetMesh(const TetMesh& mesh, const std::string& source, std::string* error,
                     const TetMeshValidationOptions& options = TetMeshValidationOptions());

}  // namespace aqs

#endif  // AQS_MESH_TET_MESH_H_
