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

// A piece of a tet mesh: its first element, its element count, and whether it is held:
// at least 3 of its vertices fixed (static or moved by a bone), not all on one line.
// Otherwise it could move rigidly, and no equilibrium of it is unique (its stiffness is
// singular).
struct MeshPiece {
  int first_element = -1;
  int elements = 0;
  bool held = false;
};

// The pieces of `mesh` (TetMeshPieces: *piece_of_element) with `fixed` (one flag per
// vertex; a vertex shared by two pieces, at an edge or a point, holds both).
std::vector<MeshPiece> DescribeMeshPieces(const TetMesh& mesh, const std::vector<bool>& fixed,
                                          std::vector<int>* piece_of_element);

// What is wrong with a piece that is not held, of `num_pieces`: a sentence naming it by
// its first element (0-based) and size.
std::string UnheldPieceText(const MeshPiece& piece, int num_pieces);

// Whether every piece is held; false with *error (UnheldPieceText of the first that is
// not, and what to do).
bool EveryPieceIsHeld(const TetMesh& mesh, const std::vector<bool>& fixed, std::string* error);

}  // namespace aqs

#endif  // AQS_MESH_TET_COMPONENTS_H_
