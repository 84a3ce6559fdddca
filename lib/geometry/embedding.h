#ifndef AQS_GEOMETRY_EMBEDDING_H_
#define AQS_GEOMETRY_EMBEDDING_H_

#include <vector>

#include <Eigen/Core>

#include "mesh/tet_mesh.h"

namespace aqs {

// Points expressed in elements of a tet mesh at rest:
//   point i = sum_k weights(k, i) * x.col(tets(k, element[i])) + offsets.col(i),
// for the rest positions x = mesh.vertices and, as the embedding defines it, for any
// deformed state x.
//   element:          num_points element indices;
//   weights:          4 x num_points, each column non-negative and summing to 1;
//   offsets:          3 x num_points; zero for a point inside its element;
//   outside_distance: 0 if point i lies in element[i] (within a small tolerance), else
//                     its distance to the mesh. An outside point is attached to the
//                     closest point of the mesh (on a boundary face of element[i]),
//                     whose barycentric weights it takes, at the constant offset from
//                     it: it then moves with that part of the surface, without the
//                     leverage that extrapolated barycentric coordinates would have far
//                     from the mesh.
struct Embedding {
  std::vector<int> element;
  Eigen::Matrix4Xd weights;
  Eigen::Matrix3Xd offsets;
  std::vector<double> outside_distance;

  int num_points() const { return static_cast<int>(element.size()); }
};

// A point counts as inside an element when all four barycentric coordinates are >=
// -kEmbeddingTolerance, so points exactly on faces, edges or vertices (also on the
// mesh boundary) are inside.
constexpr double kEmbeddingTolerance = 1e-10;

// Embeds every column of `points` (3 x K, finite; CHECK) in `mesh` (at least one
// element, indices in range; CHECK). Elements are found through a uniform grid over
// their bounding boxes (cell edge about the mean element size, at most ~4 cells per
// element), so the cost is about linear in the element and point counts. A point
// inside several elements (on a shared face, edge or vertex) goes to the one whose
// smallest barycentric coordinate is largest (the one it is deepest in), ties going to
// the lowest element index: the choice is deterministic. A point in no element goes to
// the element with the closest boundary face (a tree over the mesh's boundary
// triangles, built only if some point is outside), attached to that closest point. Flat elements never contain points.
// Threads: up to num_threads; results do not depend on the count.
Embedding EmbedPoints(const TetMesh& mesh, const Eigen::Matrix3Xd& points, int num_threads);

// The embedding operator. Point i is an affine function of the mesh state x (3 x
// num_vertices, column v the position of vertex v):
//   p_i(x) = sum_k weights(k, i) x.col(tets(k, element[i])) + offsets.col(i),
// so the points are P(x) = x A^T + O, with A the num_points x num_vertices sparse
// matrix of the weights (4 entries a row) and O = offsets. Apply is EmbeddedPositions,
// its transpose EmbeddingTranspose, one row of A with its offset EmbeddingStencil.

// One embedded point as a function of a state x:
//   p(x) = (sum_j weight[j] x.col(vertex[j])) + offset,
// vertex[j] = tets(j, element), weight[j] = weights(j, i), offset = offsets.col(i) for
// point i of an embedding; also built by hand (contact pairs) with any four vertices.
struct PointStencil {
  int vertex[4];
  double weight[4];
  Eigen::Vector3d offset;

  // p(x) for a state x (3 x num_vertices, vertex indices in range: unchecked). Summed
  // in the order of EmbeddedPositions (weights from j = 0, then the offset), so the
  // two agree bitwise.
  Eigen::Vector3d Position(const Eigen::Ref<const Eigen::Matrix3Xd>& x) const {
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int j = 0; j < 4; ++j) p += weight[j] * x.col(vertex[j]);
    return p + offset;
  }
};

// The stencil of point i (0 <= i < num_points; CHECK) of `embedding` in a mesh with
// elements tets (4 x num_tets; element[i] in range: CHECK): its row of A and offset.
PointStencil EmbeddingStencil(const Embedding& embedding, const Eigen::Matrix4Xi& tets, int i);

// The stencils of all points of `embedding` (num_points, in point order).
std::vector<PointStencil> EmbeddingStencils(const Embedding& embedding, const Eigen::Matrix4Xi& tets);

// Apply: the embedded point positions for a state x of the mesh (3 x num_vertices,
// column v the position of vertex v): 3 x num_points, column i = sum_k weights(k, i) *
// x.col(tets(k, element[i])) + offsets.col(i) (= EmbeddingStencil(i).Position(x)).
// tets: the mesh's 4 x num_elements element matrix. Element and vertex indices out of
// range: CHECK.
Eigen::Matrix3Xd EmbeddedPositions(const Embedding& embedding, const Eigen::Matrix4Xi& tets,
                                   const Eigen::Matrix3Xd& x);

// Transpose-apply: a per-point field g (3 x num_points, column i a vector at point i,
// e.g. dL/dp_i) pulled back to the mesh vertices, g A: 3 x num_vertices, column v =
// sum over points i and corners k with tets(k, element[i]) = v of weights(k, i) *
// g.col(i). The offsets, constant in x, contribute nothing, so for a loss L(P(x)) the
// result is dL/dx. Accumulated in point order, then corner order. Element and vertex
// indices out of range, or g not 3 x num_points: CHECK.
Eigen::Matrix3Xd EmbeddingTranspose(const Embedding& embedding, const Eigen::Matrix4Xi& tets,
                                    const Eigen::Matrix3Xd& g, int num_vertices);

}  // namespace aqs

#endif  // AQS_GEOMETRY_EMBEDDING_H_
