#ifndef AQS_MESH_TET_FACES_H_
#define AQS_MESH_TET_FACES_H_

// Internal: the triangles of a tet mesh grouped so that equal triangles are adjacent.
// Used by ValidateTetMesh (triangles shared by more than two elements) and
// ExtractBoundarySurface (triangles of exactly one element). Not part of the public API.

#include <vector>

#include "mesh/tet_mesh.h"

namespace aqs {
namespace mesh_internal {

// Local face f of an element is the triangle opposite its vertex f. For an element
// with positive signed volume, kOutwardFace[f] lists the local vertices of face f in
// the order whose right-hand normal points out of the element.
extern const int kOutwardFace[4][3];

// One element face, stored under its smallest vertex a; b < c are the other two.
struct TetFace {
  int b;
  int c;
  int tet;
  int local;  // face opposite vertex `local` of `tet`
};

// All 4 * num_tets faces grouped by their smallest vertex: the faces with smallest
// vertex a are faces[offsets[a] .. offsets[a + 1]), sorted by (b, c, tet), so equal
// triangles form consecutive runs. Built in linear time plus small per-vertex sorts.
struct TetFaceTable {
  std::vector<int> offsets;  // num_vertices + 1
  std::vector<TetFace> faces;
};

// Requires every index of `mesh` to be in [0, num_vertices) (CHECKed).
TetFaceTable BuildTetFaceTable(const TetMesh& mesh);

}  // namespace mesh_internal
}  // namespace aqs

#endif  // AQS_MESH_TET_FACES_H_
