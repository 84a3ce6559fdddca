#ifndef AQS_SPARSE_SPARSE_CHOLESKY_H_
#define AQS_SPARSE_SPARSE_CHOLESKY_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// A symmetric positive definite sparse matrix factorized with CHOLMOD (SuiteSparse,
// supernodal LL^T, fill-reducing ordering chosen by CHOLMOD: AMD, or METIS where AMD
// fills in badly). The symbolic analysis (ordering, elimination tree, supernodes) is
// done once per sparsity pattern and reused by every numeric Factorize().
//
// The matrix is given as the upper triangle in compressed sparse columns with 64-bit
// indices (as StiffnessPattern stores it). The pattern arrays must stay alive and
// unchanged while this object is used.
class SparseCholesky {
 public:
  // n: matrix size; column_starts: n + 1 entries; row_indices: sorted within columns,
  // row <= column. The symbolic analysis runs on the first Factorize().
  SparseCholesky(int n, const std::vector<int64_t>* column_starts,
                 const std::vector<int64_t>* row_indices);
  ~SparseCholesky();
  SparseCholesky(const SparseCholesky&) = delete;
  SparseCholesky& operator=(const SparseCholesky&) = delete;

  // Numeric factorization of the matrix with these values (CSC order of the pattern).
  // Returns false, with *error saying so, if the matrix is not positive definite;
  // failed_column() is then the (original, unpermuted) index of the column where a
  // non-positive pivot appeared.
  bool Factorize(const std::vector<double>& values, std::string* error);
  // Runs the symbolic analysis now (it otherwise runs in the first Factorize).
  void Analyze();

  bool factorized() const { return factorized_; }
  int failed_column() const { return failed_column_; }
  int size() const { return n_; }
  // Non-zeros of the factor L after the symbolic analysis (0 before).
  double factor_nonzeros() const;
  // Bytes the numeric factor takes once factorized, from the symbolic analysis (0
  // before): a supernodal L stores each supernode as a dense block (xsize doubles, the
  // non-zeros plus the zeros inside supernodes) with its row indices (ssize integers)
  // and per-supernode tables; a simplicial L its non-zeros with their row indices.
  double factor_bytes() const;
  // Name of the ordering CHOLMOD chose ("AMD", "METIS", ...).
  std::string ordering_name() const;
  // Seconds spent in the last symbolic analysis and the last numeric factorization.
  double analyze_seconds() const { return analyze_seconds_; }
  double factorize_seconds() const { return factorize_seconds_; }

  // The fill-reducing permutation CHOLMOD chose (after the analysis): row/column
  // perm[k] of A is eliminated k-th. Includes CHOLMOD's postordering.
  std::vector<int64_t> Permutation() const;

  // Solves A X = B for the n x k dense B (after a successful Factorize). Not thread-safe.
  Eigen::MatrixXd Solve(const Eigen::MatrixXd& b) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  int n_;
  bool factorized_ = false;
  int failed_column_ = -1;
  double analyze_seconds_ = 0.0;
  double factorize_seconds_ = 0.0;
};

}  // namespace aqs

#endif  // AQS_SPARSE_SPARSE_CHOLESKY_H_
