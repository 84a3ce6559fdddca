#ifndef AQS_PREPARE_FREE_PIECES_H_
#define AQS_PREPARE_FREE_PIECES_H_

#include <string>

#include "model/active_model.h"

namespace aqs {

// What RemoveFreePieces removed: pieces, elements and vertices, and the first removed
// element's index before the removal (-1: none).
struct FreePieceRemoval {
  int pieces = 0;
  int elements = 0;
  int vertices = 0;
  int first_element = -1;
};

// Every piece of model->mesh (mesh/tet_components.h: elements joined through shared
// triangles) must be held by its fixed vertices (static or driven by a bone: at least 3,
// not on one line). A piece that is not held and that surface vertices are embedded in
// would move the surface rigidly: false, with *error naming it by its first element, the
// count of embedded surface vertices, and what to do. A piece that is not held and holds
// no surface vertex (a lone element copy that plane cuts leave) does nothing for the
// model, and its stiffness is singular at every state (solves must shift it; at tight
// tolerances they stall on it, docs/solver.md): it is removed with its vertices that no
// other element uses. Elements and vertices keep their order (ElementSubset's
// numbering); mu, the embedding's elements, the static vertices and the bones' vertices
// are renumbered to match (a fixed vertex of a removed piece leaves its list). Call
// before anything indexes elements or vertices beyond those (volumetric targets,
// learned state). *removal (not null) gets what was removed.
bool RemoveFreePieces(ActiveModel* model, FreePieceRemoval* removal, std::string* error);

}  // namespace aqs

#endif  // AQS_PREPARE_FREE_PIECES_H_
