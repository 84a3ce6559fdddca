#ifndef AQS_MESH_TET_COMPONENTS_H_
#define AQS_MESH_TET_COMPONENTS_H_

#include <string>
#include <vector>

#include "mesh/tet_mesh.h"

namespace aqs {

// The pieces of a tet mesh: elements joined through shared triangles (elements that
// share only an edge or a vertex are in different pieces, which can turn about it).
// *piece_of_element (num_tets) gets each element's piece, numbered from 0 in the order
// of their first elements. Returns the number of pieces.
int TetMeshPieces(const TetMesh& mesh, std::vector<int>* piece_of_element);

// Whether every piece of `mesh` (TetMeshPieces) is held: at least 3 of its vertices are
// fixed (`fixed`: one flag per vertex; static or moved by a bone), not all on one line.
// Otherwise it could move rigidly, and no equilibrium of it is unique (its stiffness is
// singular). False with *error naming the first such piece by an element (0-based), its
// size and its fixed vertices.
bool EveryPieceIsHeld(const TetMesh& mesh, const std::vector<bool>& fixed, std::string* error);

}  // namespace aqs

#endif  // AQS_MESH_TET_COMPONENTS_H_
