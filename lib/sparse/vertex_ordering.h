#ifndef AQS_SPARSE_VERTEX_ORDERING_H_
#define AQS_SPARSE_VERTEX_ORDERING_H_

#include <vector>

#include <Eigen/Core>

namespace aqs {

// A fill-reducing elimination order of the free vertices of a tet mesh, for sparse
// Cholesky factorizations of matrices with 3x3 blocks coupling vertices that share an
// element (stiffness, Gauss-Newton normal equations). CHOLMOD chooses it on the
// vertex graph as for its own factorizations (AMD, or METIS nested dissection where AMD
// fills in badly, then an elimination-tree postorder), so a factorization in this
// block order has the fill and supernodes CHOLMOD would produce itself.
//
// tets: 4 x num_elements; fixed: one flag per vertex (fixed vertices are left out).
// Returns the free vertex indices in elimination order (in their own order, with a
// logged warning, if CHOLMOD's analysis fails: out of memory).
std::vector<int> FillReducingVertexOrder(const Eigen::Matrix4Xi& tets,
                                         const std::vector<bool>& fixed);

}  // namespace aqs

#endif  // AQS_SPARSE_VERTEX_ORDERING_H_
