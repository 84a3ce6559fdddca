#ifndef AQS_SPARSE_SPARSE_CHOLESKY_H_
#define AQS_SPARSE_SPARSE_CHOLESKY_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace aqs {

// A numeric factor's values kept in single precision, apart from the SparseCholesky
// that computed them: for a factor to be put back later as a preconditioner (not as an
// exact factor), at half the storage. `structure` identifies the symbolic analysis the
// values belong to (SparseCholesky::structure_id); empty: nothing stored.
struct StoredFactor {
  std::vector<float> values;  // the supernodal factor's L->x, xsize entries
  uint64_t structure = 0;
  bool empty() const { return values.empty(); }
  double bytes() const { return sizeof(float) * static_cast<double>(values.size()); }
  void Clear() {
    values.clear();
    values.shrink_to_fit();
    structure = 0;
  }
};

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
  // Returns false, with *error saying so, if the symbolic analysis or the factorization
  // fails (out of memory), if the matrix is not positive definite, or if an entry is
  // not finite (which CHOLMOD would pass as a pivot); failed_column() is then the
  // (original, unpermuted) index of the column where a non-positive pivot appeared, or
  // of the non-finite entry.
  bool Factorize(const std::vector<double>& values, std::string* error);
  // Runs the symbolic analysis now (it otherwise runs in the first Factorize). Returns
  // false with *error (may be null) if CHOLMOD cannot (out of memory: the ordering's
  // and the elimination tree's work space for a very large matrix); a later call tries
  // again.
  bool Analyze(std::string* error = nullptr);

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
  // Bytes a StoredFactor of this factor takes (0 before the analysis, or if the factor
  // is not supernodal).
  double stored_factor_bytes() const;
  // A fingerprint of the symbolic analysis (size, permutation, supernodes; 0 before the
  // analysis): two SparseCholesky objects with equal ids lay out their factors alike.
  uint64_t structure_id() const;
  // Copies the numeric factor into *stored (single precision). False (and *stored
  // cleared) if there is no successful factorization or the factor is not supernodal.
  bool StoreFactor(StoredFactor* stored) const;
  // Makes the values of `stored` this object's factor (rounded back to double; Solve
  // then applies an approximate inverse of the matrix they were computed for). False,
  // changing nothing, if `stored` is empty, of another structure_id, or this object has
  // no numeric factor storage yet (no Factorize has run).
  bool LoadFactor(const StoredFactor& stored);

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
  mutable uint64_t structure_id_ = 0;  // computed on first use after the analysis
};

}  // namespace aqs

#endif  // AQS_SPARSE_SPARSE_CHOLESKY_H_
