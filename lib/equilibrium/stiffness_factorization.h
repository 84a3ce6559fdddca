#ifndef AQS_EQUILIBRIUM_STIFFNESS_FACTORIZATION_H_
#define AQS_EQUILIBRIUM_STIFFNESS_FACTORIZATION_H_

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
  ~StiffnessFactorization();

  // Extra energy terms of the system (see EnergyTerm): their Hessians are added to K
  // and their gradients to EnergyAndGradient. Not owned.
  void set_energy_terms(const std::vector<const EnergyTerm*>& terms) { terms_ = terms; }
  const std::vector<const EnergyTerm*>& energy_terms() const { return terms_; }
  // The system's total energy and gradient (model plus terms) at (x, a).
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

 private:
  const ShapeTargetModel& model_;
  int num_threads_;
  StiffnessPattern pattern_;
  SparseCholesky cholesky_;
  std::vector<double> values_;
  // The diagonal of K as assembled, for shifted factorizations.
  Eigen::VectorXd diagonal_;
  std::vector<const EnergyTerm*> terms_;
  FactorizationTimings timings_;
};

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_STIFFNESS_FACTORIZATION_H_
