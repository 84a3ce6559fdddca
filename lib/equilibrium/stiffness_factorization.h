#ifndef AQS_EQUILIBRIUM_STIFFNESS_FACTORIZATION_H_
#define AQS_EQUILIBRIUM_STIFFNESS_FACTORIZATION_H_

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "equilibrium/energy_term.h"
#include "physics/actuation.h"
#include "physics/shape_target_model.h"
#include "physics/stiffness_assembly.h"
#include "sparse/sparse_cholesky.h"
#include "sparse/stiffness_pattern.h"

namespace aqs {

// How SolveAssembled may reuse the factor of an earlier state: as the preconditioner of
// conjugate gradients on the current K.
struct FactorReuseOptions {
  // CG iterations at most per right-hand side (0: never reuse, always factorize).
  int max_iterations = 20;
  // Converged when |K x - b| <= relative_tolerance |b| for every column.
  double relative_tolerance = 1e-10;
  // Give up early (and factorize) when the residual is still above this fraction of |b|
  // after `probe_iterations` iterations: a poor preconditioner (another pose's factor,
  // a large change of state).
  int probe_iterations = 6;
  double probe_tolerance = 1e-2;
  // Right-hand sides beyond which factorizing is cheaper than CG on each.
  int max_columns = 2;
  // A CG solve that needed more iterations than this shows the factor has aged: the next
  // solve at another state factorizes afresh (0: never).
  int refresh_iterations = 8;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// A factor kept for later by StiffnessFactorization::StoreFactor: its values in single
// precision and whether it had aged (see FactorReuseOptions::refresh_iterations).
struct StoredStiffnessFactor {
  StoredFactor factor;
  bool aged = false;
  bool empty() const { return factor.empty(); }
  double bytes() const { return factor.bytes(); }
};

// What the factorization did since the last ResetCounters().
struct FactorizationCounters {
  int factorizations = 0;  // numeric factorizations (successful or not)
  int reused_solves = 0;   // right-hand sides solved by CG on an earlier state's factor
  int cg_iterations = 0;   // their iterations (one solve with the factor and one K v each)
  int failed_reuses = 0;   // CG attempts abandoned (then factorized, unless indefinite)
  // Of those, the ones that met non-positive curvature p'Kp <= 0: K is not positive
  // definite, so a factorization of it would fail too, and was not tried.
  int indefinite_reuses = 0;
};

// Seconds spent by the last Factorize() and Solve() calls.
struct FactorizationTimings {
  double assembly = 0.0;
  double analysis = 0.0;  // symbolic analysis (first Factorize only)
  double factorization = 0.0;
  double solve = 0.0;
};

// The stiffness K = d2E/dx2 of a ShapeTargetModel on the free DOFs of a fixed-vertex
// set, assembled and Cholesky-factorized at a given state, for Newton steps and
// implicit differentiation. Built once per mesh and fixed set (and energy terms'
// couplings): the sparsity pattern and CHOLMOD's symbolic analysis are reused by every
// Factorize().
//
// Vectors "per vertex" are 3 x num_vertices (column v for vertex v); entries of fixed
// vertices are ignored on input and zero on output. The model must outlive this
// object. Not thread-safe.
class StiffnessFactorization {
 public:
  // couplings: vertex sets beyond the elements whose blocks energy terms fill
  // (EnergyTerm::AppendVertexCouplings of the terms to be set).
  StiffnessFactorization(const ShapeTargetModel& model, const std::vector<bool>& fixed_mask,
                         int num_threads, const std::vector<std::vector<int>>& couplings = {});
  // It keeps a reference to the model: a temporary one does not compile.
  StiffnessFactorization(ShapeTargetModel&& model, const std::vector<bool>& fixed_mask,
                         int num_threads,
                         const std::vector<std::vector<int>>& couplings = {}) = delete;
  ~StiffnessFactorization();

  // Extra energy terms of the system (see EnergyTerm): their Hessians are added to K
  // and their gradients to EnergyAndGradient. Not owned.
  void set_energy_terms(const std::vector<const EnergyTerm*>& terms) { terms_ = terms; }
  const std::vector<const EnergyTerm*>& energy_terms() const { return terms_; }
  // The system's total energy and gradient (model plus terms) at (x, a). Keeps the
  // elements' SVDs at (x, a) in polar_cache(), which Assemble at the same (x, a) reads.
  double EnergyAndGradient(const ShapeTargetModel::PositionsRef& x,
                           const ShapeTargetModel::ActuationRef& a,
                           Eigen::Matrix3Xd* gradient) const;

  // Assembles K (exact or PSD-projected) at (x, a) and factorizes it. Returns false
  // with *error if K is not positive definite, naming the vertex and component where
  // the factorization broke down.
  bool Factorize(const ShapeTargetModel::PositionsRef& x, const ShapeTargetModel::ActuationRef& a,
                 StiffnessKind kind, std::string* error);
  // The two halves of Factorize: Assemble fills values() with K at (x, a) (the model's
  // stiffness of that kind plus the energy terms' Hessians of that kind);
  // FactorizeAssembled factorizes K + shift * mean(diag K) * I (shift >= 0: 0 for K
  // itself; a positive shift makes a singular PSD matrix definite). It may be called
  // again with another shift without re-assembling.
  void Assemble(const ShapeTargetModel::PositionsRef& x, const ShapeTargetModel::ActuationRef& a,
                StiffnessKind kind);
  bool FactorizeAssembled(double relative_shift, std::string* error);
  bool factorized() const { return cholesky_.factorized(); }
  // Runs CHOLMOD's symbolic analysis now (it otherwise runs in the first factorization),
  // e.g. to read the factor's size (cholesky().factor_nonzeros()) before factorizing.
  // False with *error (may be null) if it fails (SparseCholesky::Analyze); the sizes
  // then read 0, and the first factorization tries again and reports the failure.
  bool Analyze(std::string* error = nullptr) { return cholesky_.Analyze(error); }
  // Whether the factor is of values() as assembled (unshifted), so that Solve is exact.
  bool factor_current() const { return factor_current_; }

  // K x = b for K = values() as last assembled, b (free DOFs, k columns; see SolveFree).
  // With the factor current: a direct solve. Otherwise, when a factor of an earlier
  // state exists, K is close enough to it (CG converges within reuse's limits) and there
  // are at most reuse.max_columns columns: preconditioned conjugate gradients, without a
  // factorization. Otherwise values() is factorized first; false with *error if that
  // fails (K not positive definite).
  bool SolveAssembled(const Eigen::MatrixXd& b, const FactorReuseOptions& reuse, Eigen::MatrixXd* x,
                      std::string* error);
  // The CG half of SolveAssembled alone: false (x unspecified, nothing factorized) if
  // there is no factor, CG meets non-positive curvature or does not converge in time.
  bool SolveReusingFactor(const Eigen::MatrixXd& b, const FactorReuseOptions& reuse,
                          Eigen::MatrixXd* x);
  // Whether the last SolveReusingFactor failed because CG met a direction p with
  // p'Kp <= 0 (K = values()): a proof that K is not positive definite, so that an exact
  // factorization of it would fail. False after a success, a give-up for slow
  // convergence, a call that did not run CG, or a new Assemble.
  bool last_reuse_found_indefinite() const { return last_reuse_found_indefinite_; }
  // With last_reuse_found_indefinite(): p'Kp / (p'p mean|diag K|) <= 0 for the direction
  // p CG met, an upper bound on K's smallest eigenvalue relative to its mean diagonal (a
  // diagnostic: how indefinite K is). 0 otherwise.
  double last_reuse_relative_curvature() const { return last_reuse_relative_curvature_; }
  // K v for K = values() (free DOFs).
  Eigen::VectorXd MultiplyAssembled(const Eigen::VectorXd& v) const;
  // K v for the K whose upper-triangle CSC values (in pattern()'s order) are `values`: a
  // copy of values() taken after an earlier Assemble (free DOFs).
  Eigen::VectorXd MultiplyValues(const std::vector<double>& values, const Eigen::VectorXd& v) const;
  // mean_i |K_ii| for the K whose values (as for MultiplyValues) are `values`.
  double MeanAbsDiagonal(const std::vector<double>& values) const;
  // The next SolveAssembled / SolveReusingFactor factorizes instead of reusing the
  // factor held now: for a caller that knows that factor belongs to another system (a
  // solver shared between poses moving on to the next pose). Later solves reuse the new
  // factor as usual.
  void RequestRefresh() { refresh_requested_ = true; }
  // Whether the next solve will factorize afresh instead of reusing the factor held now.
  bool refresh_requested() const { return refresh_requested_; }

  // Keeps the factor held now in *stored (single precision, half a factor's storage);
  // false, with *stored cleared, if no factor is held. For a solver shared between
  // systems of one pattern (the poses of a training set) that keeps each system's factor
  // between its visits.
  bool StoreFactor(StoredStiffnessFactor* stored) const;
  // Whether the factor held is a restored copy, not refactorized since (storing it again
  // would give the same values).
  bool factor_rounded() const { return factor_rounded_; }
  // Makes a stored factor the one held, as a factor of an earlier state: later solves
  // use it as CG's preconditioner (SolveReusingFactor), never as an exact factor, and
  // factorize afresh if it had aged. Its rounding costs CG a few iterations even on the
  // matrix it was computed from (4 to a relative residual of 1e-10 at 232,635 elements,
  // against 1 with the exact factor): while it is held, SolveReusingFactor allows
  // kRoundedFactorIterations more than FactorReuseOptions says, before giving up and
  // before judging the factor aged. False, changing nothing, if it is empty or of
  // another pattern's analysis (cholesky().structure_id()), or nothing was factorized
  // here yet (the storage it is copied into does not exist).
  bool RestoreFactor(const StoredStiffnessFactor& stored);
  static constexpr int kRoundedFactorIterations = 3;

  const FactorizationCounters& counters() const { return counters_; }
  void ResetCounters() { counters_ = FactorizationCounters(); }
  // Counts the changes of K as assembled (values()) and of the factor held: every
  // Assemble, factorization (FactorizeAssembled, also inside SolveAssembled) and
  // RestoreFactor adds one (ResetCounters does not reset it). A user of the factor made
  // at one state (EquilibriumDifferentiator) records it and checks that it is unchanged
  // before solving with it: a solver sharing the factorization may have moved on.
  int64_t generation() const { return generation_; }

  // K^-1 b for per-vertex b.
  Eigen::Matrix3Xd Solve(const Eigen::Matrix3Xd& b);
  // K^-1 B for k right-hand sides, each a column of num_dofs free values
  // (free vertex f's DOFs at rows 3f, 3f+1, 3f+2; see StiffnessPattern).
  Eigen::MatrixXd SolveFree(const Eigen::MatrixXd& b);

  // Per-vertex <-> free-DOF vectors.
  Eigen::VectorXd GatherFree(const Eigen::Matrix3Xd& per_vertex) const;
  Eigen::Matrix3Xd ScatterFree(const double* free_values) const;

  const ShapeTargetModel& model() const { return model_; }
  const StiffnessPattern& pattern() const { return pattern_; }
  const SparseCholesky& cholesky() const { return cholesky_; }
  const std::vector<double>& values() const { return values_; }
  int num_threads() const { return num_threads_; }
  const FactorizationTimings& timings() const { return timings_; }
  // The elements' SVDs at the state of the last EnergyAndGradient (see PolarCache).
  const PolarCache& polar_cache() const { return polar_cache_; }

 private:
  const ShapeTargetModel& model_;
  int num_threads_;
  StiffnessPattern pattern_;
  SparseCholesky cholesky_;
  std::vector<double> values_;
  // The diagonal of K as assembled, for shifted factorizations.
  Eigen::VectorXd diagonal_;
  bool factor_current_ = false;
  bool refresh_requested_ = false;  // the last reuse took long: factorize next time
  // The factor held is a restored single-precision copy (RestoreFactor) until the next
  // factorization: CG on it is allowed kRoundedFactorIterations more iterations.
  bool factor_rounded_ = false;
  bool last_reuse_found_indefinite_ = false;
  double last_reuse_relative_curvature_ = 0.0;
  FactorizationCounters counters_;
  int64_t generation_ = 0;
  std::vector<const EnergyTerm*> terms_;
  FactorizationTimings timings_;
  mutable PolarCache polar_cache_;  // a cache: filled by the const EnergyAndGradient
};

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_STIFFNESS_FACTORIZATION_H_
