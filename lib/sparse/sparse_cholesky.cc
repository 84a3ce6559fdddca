#include "sparse/sparse_cholesky.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

#include <cholmod.h>
#include <glog/logging.h>

#include "util/fnv_hash.h"
#include "util/wall_timer.h"

namespace aqs {

struct SparseCholesky::Impl {
  cholmod_common common;
  cholmod_sparse matrix;  // header only: points at the caller's pattern (and values)
  cholmod_factor* factor = nullptr;
  const std::vector<int64_t>* column_starts;
  const std::vector<int64_t>* row_indices;
};

SparseCholesky::SparseCholesky(int n, const std::vector<int64_t>* column_starts,
                               const std::vector<int64_t>* row_indices)
    : impl_(new Impl), n_(n) {
  CHECK_EQ(column_starts->size(), static_cast<size_t>(n) + 1);
  CHECK_EQ(row_indices->size(), static_cast<size_t>(column_starts->back()));
  impl_->column_starts = column_starts;
  impl_->row_indices = row_indices;
  cholmod_l_start(&impl_->common);
  impl_->common.print = 0;             // errors are reported through our messages
  impl_->common.error_handler = nullptr;
  impl_->common.supernodal = CHOLMOD_SUPERNODAL;
  impl_->common.final_ll = 1;

  cholmod_sparse& a = impl_->matrix;
  std::memset(&a, 0, sizeof(a));
  a.nrow = n;
  a.ncol = n;
  a.nzmax = row_indices->size();
  a.p = const_cast<int64_t*>(column_starts->data());
  a.i = const_cast<int64_t*>(row_indices->data());
  a.nz = nullptr;
  a.z = nullptr;
  a.stype = 1;  // upper triangle stored
  a.itype = CHOLMOD_LONG;
  a.xtype = CHOLMOD_REAL;
  a.dtype = CHOLMOD_DOUBLE;
  a.sorted = 1;
  a.packed = 1;
}

SparseCholesky::~SparseCholesky() {
  if (impl_->factor != nullptr) cholmod_l_free_factor(&impl_->factor, &impl_->common);
  cholmod_l_finish(&impl_->common);
}

bool SparseCholesky::Analyze(std::string* error) {
  if (impl_->factor != nullptr) return true;
  WallTimer timer;
  // The analysis looks at the pattern only.
  impl_->matrix.xtype = CHOLMOD_PATTERN;
  impl_->matrix.x = nullptr;
  impl_->factor = cholmod_l_analyze(&impl_->matrix, &impl_->common);
  impl_->matrix.xtype = CHOLMOD_REAL;
  analyze_seconds_ = timer.Seconds();
  if (impl_->factor != nullptr) return true;
  if (error != nullptr) {
    std::ostringstream out;
    out << "CHOLMOD's symbolic analysis of the " << n_ << " x " << n_ << " matrix ("
        << impl_->row_indices->size() << " stored non-zeros) failed (status "
        << impl_->common.status
        << (impl_->common.status == CHOLMOD_OUT_OF_MEMORY ? ": out of memory" : "") << ")";
    *error = out.str();
  }
  return false;
}

bool SparseCholesky::Factorize(const std::vector<double>& values, std::string* error) {
  CHECK_EQ(values.size(), impl_->row_indices->size());
  factorized_ = false;
  failed_column_ = -1;
  // CHOLMOD (and the BLAS under it) takes NaN pivots for positive ones: a matrix with a
  // non-finite entry "factorizes" into NaN solves. Refused here, naming the entry.
  for (size_t k = 0; k < values.size(); ++k) {
    if (std::isfinite(values[k])) continue;
    const std::vector<int64_t>& starts = *impl_->column_starts;
    const auto after = std::upper_bound(starts.begin(), starts.end(), static_cast<int64_t>(k));
    const int64_t column = (after - starts.begin()) - 1;
    failed_column_ = static_cast<int>(column);
    std::ostringstream out;
    out << "the matrix has a non-finite entry (" << values[k] << ") at row "
        << (*impl_->row_indices)[k] << ", column " << column << " of " << n_;
    *error = out.str();
    return false;
  }
  if (!Analyze(error)) return false;
  WallTimer timer;
  impl_->matrix.x = const_cast<double*>(values.data());
  const int ok = cholmod_l_factorize(&impl_->matrix, impl_->factor, &impl_->common);
  impl_->matrix.x = nullptr;
  factorize_seconds_ = timer.Seconds();
  factorized_ = false;
  failed_column_ = -1;
  if (!ok || impl_->common.status < CHOLMOD_OK) {
    std::ostringstream out;
    out << "CHOLMOD factorization failed (status " << impl_->common.status
        << (impl_->common.status == CHOLMOD_OUT_OF_MEMORY ? ": out of memory" : "") << ")";
    *error = out.str();
    return false;
  }
  const cholmod_factor* l = impl_->factor;
  if (impl_->common.status == CHOLMOD_NOT_POSDEF || l->minor < l->n) {
    const int64_t* perm = static_cast<const int64_t*>(l->Perm);
    failed_column_ = perm != nullptr ? static_cast<int>(perm[l->minor]) : static_cast<int>(l->minor);
    std::ostringstream out;
    out << "the matrix is not positive definite: CHOLMOD met a non-positive pivot at column "
        << failed_column_ << " of " << n_ << " (step " << l->minor << " of the elimination)";
    *error = out.str();
    return false;
  }
  factorized_ = true;
  return true;
}

double SparseCholesky::factor_nonzeros() const {
  if (impl_->factor == nullptr) return 0.0;
  return impl_->common.lnz;
}

double SparseCholesky::factor_bytes() const {
  const cholmod_factor* l = impl_->factor;
  if (l == nullptr) return 0.0;
  constexpr double kIndex = sizeof(int64_t);
  const double n = static_cast<double>(l->n);
  // Perm, ColCount and the permutation's inverse, per column.
  double bytes = 3.0 * kIndex * n;
  if (l->is_super) {
    const double supernodes = static_cast<double>(l->nsuper);
    bytes += sizeof(double) * static_cast<double>(l->xsize) +
             kIndex * (static_cast<double>(l->ssize) + 4.0 * (supernodes + 1.0));
  } else {
    const double nonzeros = impl_->common.lnz + n;  // with the diagonal
    bytes += (sizeof(double) + kIndex) * nonzeros + 4.0 * kIndex * n;
  }
  return bytes;
}

double SparseCholesky::stored_factor_bytes() const {
  const cholmod_factor* l = impl_->factor;
  if (l == nullptr || !l->is_super) return 0.0;
  return sizeof(float) * static_cast<double>(l->xsize);
}

uint64_t SparseCholesky::structure_id() const {
  const cholmod_factor* l = impl_->factor;
  if (l == nullptr) return 0;
  if (structure_id_ != 0) return structure_id_;
  const int64_t sizes[5] = {static_cast<int64_t>(l->n), static_cast<int64_t>(l->xsize),
                            static_cast<int64_t>(l->nsuper), static_cast<int64_t>(l->ssize),
                            static_cast<int64_t>(l->is_super)};
  uint64_t hash = Fnv1a(sizes, sizeof(sizes), kFnvOffsetBasis);
  if (l->Perm != nullptr) hash = Fnv1a(l->Perm, sizeof(int64_t) * l->n, hash);
  if (l->is_super && l->super != nullptr) {
    const size_t bytes = sizeof(int64_t) * (l->nsuper + 1);
    hash = Fnv1a(l->super, bytes, hash);
    hash = Fnv1a(l->pi, bytes, hash);
    hash = Fnv1a(l->px, bytes, hash);
  }
  structure_id_ = hash == 0 ? 1 : hash;
  return structure_id_;
}

bool SparseCholesky::StoreFactor(StoredFactor* stored) const {
  const cholmod_factor* l = impl_->factor;
  if (!factorized_ || l == nullptr || !l->is_super || l->x == nullptr) {
    stored->Clear();
    return false;
  }
  const double* x = static_cast<const double*>(l->x);
  stored->values.resize(l->xsize);
  for (size_t k = 0; k < l->xsize; ++k) stored->values[k] = static_cast<float>(x[k]);
  stored->structure = structure_id();
  return true;
}

bool SparseCholesky::LoadFactor(const StoredFactor& stored) {
  cholmod_factor* l = impl_->factor;
  if (stored.empty() || l == nullptr || !l->is_super || l->x == nullptr ||
      l->xtype != CHOLMOD_REAL || stored.values.size() != l->xsize ||
      stored.structure != structure_id()) {
    return false;
  }
  double* x = static_cast<double*>(l->x);
  for (size_t k = 0; k < l->xsize; ++k) x[k] = stored.values[k];
  l->minor = l->n;  // a complete factor (the last Factorize may have stopped early)
  factorized_ = true;
  failed_column_ = -1;
  return true;
}

std::string SparseCholesky::ordering_name() const {
  if (impl_->factor == nullptr) return "none";
  switch (impl_->factor->ordering) {
    case CHOLMOD_NATURAL: return "natural";
    case CHOLMOD_GIVEN: return "given";
    case CHOLMOD_AMD: return "AMD";
    case CHOLMOD_METIS: return "METIS";
    case CHOLMOD_NESDIS: return "NESDIS";
    case CHOLMOD_COLAMD: return "COLAMD";
    case CHOLMOD_POSTORDERED: return "postordered";
    default: return "unknown";
  }
}

std::vector<int64_t> SparseCholesky::Permutation() const {
  CHECK(impl_->factor != nullptr) << "Permutation() needs the symbolic analysis";
  const int64_t* perm = static_cast<const int64_t*>(impl_->factor->Perm);
  std::vector<int64_t> out(n_);
  for (int k = 0; k < n_; ++k) out[k] = perm != nullptr ? perm[k] : k;
  return out;
}

Eigen::MatrixXd SparseCholesky::Solve(const Eigen::MatrixXd& b) const {
  CHECK(factorized_) << "Solve() needs a successful Factorize()";
  CHECK_EQ(b.rows(), n_);
  cholmod_common* common = &impl_->common;
  Eigen::MatrixXd x(b.rows(), b.cols());
  if (b.cols() == 0) return x;
  cholmod_dense rhs;
  std::memset(&rhs, 0, sizeof(rhs));
  rhs.nrow = b.rows();
  rhs.ncol = b.cols();
  rhs.nzmax = b.size();
  rhs.d = b.rows();
  rhs.x = const_cast<double*>(b.data());
  rhs.xtype = CHOLMOD_REAL;
  rhs.dtype = CHOLMOD_DOUBLE;
  cholmod_dense* solution = cholmod_l_solve(CHOLMOD_A, impl_->factor, &rhs, common);
  CHECK(solution != nullptr) << "CHOLMOD solve failed (status " << common->status << ")";
  std::memcpy(x.data(), solution->x, sizeof(double) * b.size());
  cholmod_l_free_dense(&solution, common);
  return x;
}

}  // namespace aqs
