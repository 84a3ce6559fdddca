#include "equilibrium/stiffness_factorization.h"

#include <cmath>
#include <sstream>

#include <glog/logging.h>

#include "util/option_checks.h"
#include "util/wall_timer.h"

namespace aqs {

bool FactorReuseOptions::Validate(std::string* error) const {
  return OptionChecks()
      .IntAtLeast("max_iterations", max_iterations, 0)
      .InRange("relative_tolerance", relative_tolerance, 0.0, 1.0)
      .IntAtLeast("probe_iterations", probe_iterations, 0)
      .InRange("probe_tolerance", probe_tolerance, 0.0, 1.0)
      .IntAtLeast("max_columns", max_columns, 0)
      .IntAtLeast("refresh_iterations", refresh_iterations, 0)
      .Done(error);
}

StiffnessFactorization::StiffnessFactorization(const ShapeTargetModel& model,
                                               const std::vector<bool>& fixed_mask,
                                               int num_threads,
                                               const std::vector<std::vector<int>>& couplings)
    : model_(model),
      num_threads_(num_threads),
      pattern_(model.tets(), fixed_mask, couplings),
      cholesky_(pattern_.num_dofs(), &pattern_.column_starts(), &pattern_.row_indices()) {
  CHECK_EQ(static_cast<int>(fixed_mask.size()), model.num_vertices());
}

StiffnessFactorization::~StiffnessFactorization() = default;

bool StiffnessFactorization::Factorize(const ShapeTargetModel::PositionsRef& x,
                                       const ShapeTargetModel::ActuationRef& a, StiffnessKind kind,
                                       std::string* error) {
  Assemble(x, a, kind);
  return FactorizeAssembled(0.0, error);
}

void StiffnessFactorization::Assemble(const ShapeTargetModel::PositionsRef& x,
                                      const ShapeTargetModel::ActuationRef& a, StiffnessKind kind) {
  timings_ = FactorizationTimings();
  ++generation_;
  WallTimer timer;
  AssembleStiffness(model_, pattern_, x, a, kind, num_threads_, &values_, &polar_cache_);
  for (const EnergyTerm* term : terms_) {
    CHECK(term->SupportsStiffness()) << "an energy term without a stiffness on the mesh's pattern";
    term->AddStiffness(x, pattern_, kind, &values_);
  }
  // The diagonal entry of column c is the last of the column (rows sorted, row <= c).
  const std::vector<int64_t>& starts = pattern_.column_starts();
  diagonal_.resize(pattern_.num_dofs());
  for (int c = 0; c < pattern_.num_dofs(); ++c) diagonal_[c] = values_[starts[c + 1] - 1];
  factor_current_ = false;
  last_reuse_found_indefinite_ = false;  // it spoke of the K assembled before
  last_reuse_relative_curvature_ = 0.0;
  timings_.assembly = timer.Seconds();
}

bool StiffnessFactorization::FactorizeAssembled(double relative_shift, std::string* error) {
  CHECK_GE(relative_shift, 0.0);
  if (pattern_.num_dofs() == 0) {
    *error = "every vertex is fixed: the stiffness has no free degrees of freedom";
    return false;
  }
  CHECK_EQ(diagonal_.size(), pattern_.num_dofs()) << "Assemble first";
  const std::vector<int64_t>& starts = pattern_.column_starts();
  const double shift = relative_shift * diagonal_.cwiseAbs().mean();
  for (int c = 0; c < pattern_.num_dofs(); ++c) values_[starts[c + 1] - 1] = diagonal_[c] + shift;
  const bool first = cholesky_.factor_nonzeros() == 0.0;
  std::string cholmod_error;
  ++counters_.factorizations;
  ++generation_;
  const bool ok = cholesky_.Factorize(values_, &cholmod_error);
  // values() stay K itself (unshifted) for products and later shifts.
  for (int c = 0; c < pattern_.num_dofs(); ++c) values_[starts[c + 1] - 1] = diagonal_[c];
  factor_current_ = ok && relative_shift == 0.0;
  refresh_requested_ = false;
  factor_rounded_ = false;
  if (first) timings_.analysis = cholesky_.analyze_seconds();
  timings_.factorization += cholesky_.factorize_seconds();
  if (!ok) {
    std::ostringstream out;
    out << "the stiffness K = d2E/dx2 cannot be factorized at this state: " << cholmod_error;
    const int column = cholesky_.failed_column();
    if (column >= 0) {
      out << "; that column is DOF " << "xyz"[column % 3] << " of vertex "
          << pattern_.vertex_of_free(column / 3)
          << ". K must be positive definite: the state may not be a stable equilibrium, or "
             "the fixed vertices may not prevent rigid motion";
    }
    *error = out.str();
    return false;
  }
  return true;
}

double StiffnessFactorization::EnergyAndGradient(const ShapeTargetModel::PositionsRef& x,
                                                 const ShapeTargetModel::ActuationRef& a,
                                                 Eigen::Matrix3Xd* gradient) const {
  return TotalEnergyAndGradient(model_, terms_, x, a, gradient, num_threads_, &polar_cache_);
}

Eigen::VectorXd StiffnessFactorization::GatherFree(const Eigen::Matrix3Xd& per_vertex) const {
  CHECK_EQ(per_vertex.cols(), model_.num_vertices());
  Eigen::VectorXd free(pattern_.num_dofs());
  for (int f = 0; f < pattern_.num_free_vertices(); ++f) {
    free.segment<3>(3 * f) = per_vertex.col(pattern_.vertex_of_free(f));
  }
  return free;
}

Eigen::Matrix3Xd StiffnessFactorization::ScatterFree(const double* free_values) const {
  Eigen::Matrix3Xd out = Eigen::Matrix3Xd::Zero(3, model_.num_vertices());
  for (int f = 0; f < pattern_.num_free_vertices(); ++f) {
    out.col(pattern_.vertex_of_free(f)) = Eigen::Map<const Eigen::Vector3d>(free_values + 3 * f);
  }
  return out;
}

Eigen::VectorXd StiffnessFactorization::MultiplyAssembled(const Eigen::VectorXd& v) const {
  return MultiplyValues(values_, v);
}

double StiffnessFactorization::MeanAbsDiagonal(const std::vector<double>& values) const {
  CHECK_EQ(values.size(), values_.size());
  const std::vector<int64_t>& starts = pattern_.column_starts();
  double sum = 0.0;
  // The diagonal entry of column c is the last of the column (rows sorted, row <= c).
  for (int c = 0; c < pattern_.num_dofs(); ++c) sum += std::abs(values[starts[c + 1] - 1]);
  return pattern_.num_dofs() > 0 ? sum / pattern_.num_dofs() : 0.0;
}

Eigen::VectorXd StiffnessFactorization::MultiplyValues(const std::vector<double>& values,
                                                       const Eigen::VectorXd& v) const {
  // Upper-triangle CSC of a symmetric matrix: each stored (i, j), i < j, acts twice.
  const std::vector<int64_t>& starts = pattern_.column_starts();
  const std::vector<int64_t>& rows = pattern_.row_indices();
  const int n = pattern_.num_dofs();
  CHECK_EQ(v.size(), n);
  CHECK_EQ(values.size(), values_.size());
  Eigen::VectorXd out = Eigen::VectorXd::Zero(n);
  for (int j = 0; j < n; ++j) {
    double sum = 0.0;
    const double vj = v[j];
    for (int64_t p = starts[j]; p < starts[j + 1]; ++p) {
      const int64_t i = rows[p];
      const double value = values[p];
      if (i == j) {
        sum += value * vj;
      } else {
        out[i] += value * vj;
        sum += value * v[i];
      }
    }
    out[j] += sum;
  }
  return out;
}

bool StiffnessFactorization::SolveReusingFactor(const Eigen::MatrixXd& b,
                                                const FactorReuseOptions& reuse,
                                                Eigen::MatrixXd* x) {
  last_reuse_found_indefinite_ = false;
  last_reuse_relative_curvature_ = 0.0;
  if (!cholesky_.factorized() || reuse.max_iterations <= 0 || b.cols() > reuse.max_columns ||
      refresh_requested_) {
    return false;
  }
  CHECK_EQ(b.rows(), pattern_.num_dofs());
  WallTimer timer;
  const int extra = factor_rounded_ ? kRoundedFactorIterations : 0;
  const int max_iterations = reuse.max_iterations + extra;
  x->setZero(b.rows(), b.cols());
  int iterations = 0;
  bool ok = true;
  for (Eigen::Index c = 0; c < b.cols() && ok; ++c) {
    const double b_norm = b.col(c).norm();
    if (b_norm == 0.0) continue;
    // Preconditioned CG from x = 0 (r = b).
    Eigen::VectorXd solution = Eigen::VectorXd::Zero(b.rows());
    Eigen::VectorXd r = b.col(c);
    Eigen::VectorXd z = cholesky_.Solve(r);
    Eigen::VectorXd p = z;
    double rz = r.dot(z);
    ok = false;
    for (int k = 1; k <= max_iterations; ++k) {
      ++iterations;
      const Eigen::VectorXd q = MultiplyAssembled(p);
      const double curvature = p.dot(q);
      if (!(curvature > 0.0)) {  // K not positive definite along p (or not finite)
        last_reuse_found_indefinite_ = curvature <= 0.0;
        const double scale = p.squaredNorm() * diagonal_.cwiseAbs().mean();
        if (last_reuse_found_indefinite_ && scale > 0.0) {
          last_reuse_relative_curvature_ = curvature / scale;
        }
        break;
      }
      const double alpha = rz / curvature;
      solution += alpha * p;
      r -= alpha * q;
      const double residual = r.norm() / b_norm;
      if (residual <= reuse.relative_tolerance) {
        ok = true;
        break;
      }
      if (k == reuse.probe_iterations && residual > reuse.probe_tolerance) break;
      z = cholesky_.Solve(r);
      const double rz_next = r.dot(z);
      p = z + (rz_next / rz) * p;
      rz = rz_next;
    }
    if (ok) x->col(c) = solution;
  }
  counters_.cg_iterations += iterations;
  if (ok) {
    counters_.reused_solves += static_cast<int>(b.cols());
    if (reuse.refresh_iterations > 0 &&
        iterations > (reuse.refresh_iterations + extra) * b.cols()) {
      refresh_requested_ = true;
    }
  } else {
    ++counters_.failed_reuses;
    if (last_reuse_found_indefinite_) ++counters_.indefinite_reuses;
  }
  timings_.solve = timer.Seconds();
  return ok;
}

bool StiffnessFactorization::SolveAssembled(const Eigen::MatrixXd& b, const FactorReuseOptions& reuse,
                                            Eigen::MatrixXd* x, std::string* error) {
  if (!factor_current_) {
    if (SolveReusingFactor(b, reuse, x)) return true;
    if (last_reuse_found_indefinite_) {
      *error = "the stiffness K = d2E/dx2 is not positive definite at this state (conjugate "
               "gradients met a direction of non-positive curvature, so it was not "
               "factorized): the state may not be a stable equilibrium";
      return false;
    }
    if (!FactorizeAssembled(0.0, error)) return false;
  }
  *x = SolveFree(b);
  return true;
}

bool StiffnessFactorization::StoreFactor(StoredStiffnessFactor* stored) const {
  stored->aged = refresh_requested_;
  return cholesky_.StoreFactor(&stored->factor);
}

bool StiffnessFactorization::RestoreFactor(const StoredStiffnessFactor& stored) {
  if (!cholesky_.LoadFactor(stored.factor)) return false;
  ++generation_;
  factor_current_ = false;
  factor_rounded_ = true;
  refresh_requested_ = stored.aged;
  return true;
}

Eigen::MatrixXd StiffnessFactorization::SolveFree(const Eigen::MatrixXd& b) {
  WallTimer timer;
  Eigen::MatrixXd x = cholesky_.Solve(b);
  timings_.solve = timer.Seconds();
  return x;
}

Eigen::Matrix3Xd StiffnessFactorization::Solve(const Eigen::Matrix3Xd& b) {
  const Eigen::VectorXd x = SolveFree(GatherFree(b));
  return ScatterFree(x.data());
}

}  // namespace aqs
