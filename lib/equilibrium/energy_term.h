#ifndef AQS_EQUILIBRIUM_ENERGY_TERM_H_
#define AQS_EQUILIBRIUM_ENERGY_TERM_H_

#include <vector>

#include <Eigen/Core>

#include "physics/shape_target_model.h"
#include "physics/stiffness_assembly.h"
#include "sparse/stiffness_pattern.h"

namespace ceres {
class Problem;
}

namespace aqs {

// An energy added to the shape-targeting energy of a QuasistaticSolver, E_total(x) =
// E(x, a) + sum of terms. A term provides its energy, gradient and Hessian (for the
// force test and Newton steps) and its Ceres residual blocks (for Levenberg-Marquardt),
// consistent with each other: the Ceres cost of its blocks is its energy.
//
// Positions are 3 x num_vertices (column v = vertex v). A term's Hessian may only
// couple vertices that share an element of the model or that it declares together in
// AppendVertexCouplings (the stiffness pattern is the mesh's plus those). Terms are
// owned by the caller and must outlive the solvers and factorizations that use them.
// Their const methods may be called concurrently.
class EnergyTerm {
 public:
  virtual ~EnergyTerm() = default;

  // Adds the term's energy to the return value and its gradient dE/dx to *gradient
  // (3 x num_vertices, accumulated). Returns the term's energy.
  virtual double AddEnergyAndGradient(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                                      Eigen::Matrix3Xd* gradient) const = 0;

  // Whether AddStiffness gives the term's Hessian. A term without one returns false: a
  // QuasistaticSolver with such a term uses Levenberg-Marquardt only.
  virtual bool SupportsStiffness() const { return true; }

  // Whether the term's Hessian is the same at every x (a quadratic energy): then a
  // solver may keep a factorization that includes it across solves.
  virtual bool HasConstantHessian() const { return false; }

  // Appends the vertex sets (simulation vertex indices) whose pairs the term's Hessian
  // couples beyond the model's elements: the stiffness pattern then holds every pair of
  // each set. The sets must not change while a factorization built with them is in use.
  virtual void AppendVertexCouplings(std::vector<std::vector<int>>* couplings) const {}

  // Adds the term's Hessian at x into `values` (upper-triangle CSC of `pattern`, as
  // AssembleStiffness fills it; pattern.VertexBlockOffset finds any coupled pair).
  // Entries of fixed vertices are dropped. kExact: the Hessian itself; kProjected and
  // kRotationFixed: a positive semi-definite approximation of it (e.g. its Gauss-Newton
  // part), for descent steps far from equilibrium (MinimizeEnergyNewton) and the
  // preconditioner of MinimizeEnergyLbfgs.
  virtual void AddStiffness(const Eigen::Ref<const Eigen::Matrix3Xd>& x,
                            const StiffnessPattern& pattern, StiffnessKind kind,
                            std::vector<double>* values) const = 0;

  // Adds the term's residual blocks to `problem`. vertex_block(v) is the parameter
  // block (3 doubles) of vertex v; blocks of vertices not yet in the problem may be
  // added by this call. The term may keep pointers to its own data in the cost
  // functions so that later changes (e.g. new targets) take effect without rebuilding.
  virtual void AddResidualBlocks(ceres::Problem* problem,
                                 const std::vector<double*>& vertex_blocks) const = 0;
};

// E(x, a) + sum of the terms' energies, and the total gradient (3 x num_vertices).
// `cache` as in ShapeTargetModel::EnergyAndGradient (may be null).
double TotalEnergyAndGradient(const ShapeTargetModel& model,
                              const std::vector<const EnergyTerm*>& terms,
                              const ShapeTargetModel::PositionsRef& x,
                              const ShapeTargetModel::ActuationRef& a,
                              Eigen::Matrix3Xd* gradient, int num_threads,
                              PolarCache* cache = nullptr);

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_ENERGY_TERM_H_
