#ifndef AQS_MESH_ELEMENT_SUBSET_H_
#define AQS_MESH_ELEMENT_SUBSET_H_

#include <vector>

#include "mesh/tet_mesh.h"

namespace aqs {

// The mesh made of the elements `elements` of `mesh` (0-based indices, in the order
// given; each at most once), with the vertices they use renumbered in increasing order
// of their index in `mesh` and every unused vertex dropped. *kept_vertices (may be null):
// per vertex of the result, its index in `mesh`.
TetMesh ElementSubset(const TetMesh& mesh, const std::vector<int>& elements,
                      std::vector<int>* kept_vertices = nullptr);

// Per vertex of `mesh`, the number of elements that use it (size num_vertices; 0 for
// an unused vertex).
std::vector<int> VertexElementCounts(const TetMesh& mesh);

// Removes, repeatedly until none is left, every element one of whose vertices is used
// by fewer than `min_elements_per_vertex` elements, then drops unused vertices
// (ElementSubset's numbering). Such a vertex hangs on the rest of the mesh by one or
// two elements: compressed or turned far from their shape targets, those elements'
// energy is not convex in it and nothing else holds it, so equilibria there have a
// stiffness that is not positive definite. `min_elements_per_vertex` <= 1 changes
// nothing. *num_removed (may be null): the elements removed; *kept_vertices (may be
// null): per vertex of the result, its index in `mesh`. The result may be empty (a mesh
// with no vertex held by enough elements).
TetMesh PruneWeaklyHeldElements(const TetMesh& mesh, int min_elements_per_vertex,
                                int* num_removed = nullptr,
                                std::vector<int>* kept_vertices = nullptr);

}  // namespace aqs

#endif  // AQS_MESH_ELEMENT_SUBSET_H_
