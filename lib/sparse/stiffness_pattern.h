#ifndef AQS_SPARSE_STIFFNESS_PATTERN_H_
#define AQS_SPARSE_STIFFNESS_PATTERN_H_

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// The sparsity structure of the stiffness K = d2E/dx2 restricted to free DOFs, built
// once per mesh and set of fixed vertices.
//
// DOF numbering: free vertices are numbered in increasing vertex order; free vertex
// number f owns DOFs 3 f, 3 f + 1, 3 f + 2 (x, y, z). Fixed vertices have no DOFs.
//
// Storage: compressed sparse columns (CSC) of the UPPER triangle (row <= column),
// rows sorted within each column, 64-bit indices (CHOLMOD's "long" interface,
// stype = +1). Column 3 v + d holds, for each free neighbour u < v of vertex v in
// increasing order, rows 3u, 3u+1, 3u+2, then the diagonal-block rows 3v .. 3v+d.
class StiffnessPattern {
 public:
  // tets: 4 x num_elements; fixed: one flag per vertex. couplings: further vertex sets
  // whose every pair gets a block (e.g. contact pairs, EnergyTerm::AppendVertexCouplings).
  StiffnessPattern(const Eigen::Matrix4Xi& tets, const std::vector<bool>& fixed,
                   const std::vector<std::vector<int>>& couplings = {});

  int num_vertices() const { return static_cast<int>(vertex_to_free_.size()); }
  int num_free_vertices() const { return static_cast<int>(free_to_vertex_.size()); }
  int num_dofs() const { return 3 * num_free_vertices(); }
  int64_t num_nonzeros() const { return static_cast<int64_t>(row_indices_.size()); }

  // Free index of vertex v, or -1 if v is fixed.
  int free_index(int v) const { return vertex_to_free_[v]; }
  int vertex_of_free(int f) const { return free_to_vertex_[f]; }

  const std::vector<int64_t>& column_starts() const { return column_starts_; }  // num_dofs + 1
  const std::vector<int64_t>& row_indices() const { return row_indices_; }

  // Where element e's Hessian block coupling its local vertices k and l goes.
  // For free vertices u = tets(k, e), v = tets(l, e) with free_index(u) <= free_index(v),
  // entry (3 fu + c, 3 fv + d) of K is stored at BlockOffset(e, k, l, d) + c, for all
  // c, d when u != v and for c <= d when u == v. Returns -1 if either vertex is fixed or
  // free_index(u) > free_index(v) (then use (l, k) transposed).
  int64_t BlockOffset(int e, int k, int l, int d) const;
  // The same for any two vertices u, v whose block is in the pattern (sharing an element
  // or a coupling), by search in v's column: entry (3 fu + c, 3 fv + d) is at
  // VertexBlockOffset(u, v, d) + c. Returns -1 if either vertex is fixed,
  // free_index(u) > free_index(v) or the block is not in the pattern.
  int64_t VertexBlockOffset(int u, int v, int d) const;

 private:
  std::vector<int> vertex_to_free_;
  std::vector<int> free_to_vertex_;
  std::vector<int64_t> column_starts_;
  std::vector<int64_t> row_indices_;
  // Per element and local pair (k, l), k, l in 0..3: position of u among the entries
  // before the diagonal block of v's columns (in units of 3 rows), or -1.
  std::vector<int32_t> pair_slot_;  // 16 per element
  Eigen::Matrix4Xi tets_;
};

// The largest column norm of a per-vertex field (3 x num_vertices) over the free vertices
// of `pattern`: for a gradient dE/dx, the largest residual force.
double MaxFreeVertexNorm(const StiffnessPattern& pattern, const Eigen::Matrix3Xd& per_vertex);

// Adds a dense symmetric Hessian over `vertices` (3 n x 3 n, vertex i's DOFs at rows
// 3 i .. 3 i + 2; vertices distinct) into `values` (upper-triangle CSC of `pattern`).
// Blocks of fixed vertices are dropped; every pair of free vertices must be in the
// pattern (CHECKed).
void AddVertexHessian(const std::vector<int>& vertices, const Eigen::MatrixXd& hessian,
                      const StiffnessPattern& pattern, std::vector<double>* values);

}  // namespace aqs

#endif  // AQS_SPARSE_STIFFNESS_PATTERN_H_
