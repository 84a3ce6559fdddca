#ifndef AQS_MESH_LATTICE_H_
#define AQS_MESH_LATTICE_H_

#include <string>

#include <Eigen/Core>

#include "mesh/tet_mesh.h"

namespace aqs {

enum class LatticeType {
  // Each cube split into 6 tetrahedra around its (0,0,0)-(1,1,1) diagonal (Kuhn /
  // Freudenthal split); conforming across cubes; (nx+1)(ny+1)(nz+1) vertices.
  kKuhn,
  // Body-centred cubic: cube corners plus cube centres; 4 tetrahedra around each
  // face shared by two cubes, 2 on each boundary face of the box. Better shaped
  // elements (all congruent in the interior).
  kBcc,
};

struct LatticeOptions {
  int nx = 1, ny = 1, nz = 1;  // cubes along x, y, z (each >= 1)
  double spacing = 1.0;        // cube edge length
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // minimum corner of the box
  LatticeType type = LatticeType::kKuhn;

  // Whether MakeLatticeMesh can build these options: cube counts >= 1, a finite positive
  // spacing whose cube (an element's volume scale) is a normal double, a finite origin,
  // and element indices that fit an int (at most about 44 million cubes). False with
  // *error naming the field. (The memory such a mesh's simulation needs is the caller's
  // to check.)
  bool Validate(std::string* error) const;
};

// A box of nx x ny x nz cubes split into tetrahedra, every element with positive
// signed volume (CHECK: options.Validate). Corner vertex (i, j, k) has index
// i + (nx+1) (j + (ny+1) k); BCC centres follow all corners, centre (i, j, k) at index
// num_corners + i + nx (j + ny k).
TetMesh MakeLatticeMesh(const LatticeOptions& options);

}  // namespace aqs

#endif  // AQS_MESH_LATTICE_H_
