#ifndef AQS_DIFF_EQUILIBRIUM_DIFFERENTIATOR_H_
#define AQS_DIFF_EQUILIBRIUM_DIFFERENTIATOR_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "equilibrium/stiffness_factorization.h"
#include "physics/actuation.h"
#include "physics/shape_target_model.h"

namespace aqs {

struct EquilibriumDifferentiatorOptions {
  // Threads for stiffness assembly and per-element accumulation.
  int num_threads = 2;
  // With reuse.max_iterations > 0, Prepare only assembles K, and the adjoint solves
  // (the bool overloads of SolveAdjoint and LossGradient) first try conjugate gradients
  // preconditioned by the factor the shared StiffnessFactorization holds from an earlier
  // state, e.g. the last Newton step of the solve that found x: then one factorization
  // serves the equilibrium and its gradient. 0 (default): Prepare factorizes K.
  FactorReuseOptions reuse = {0, 1e-10, 6, 1e-2, 1, 8};

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// Timings of the last Prepare() and gradient/JVP call, in seconds.
struct DifferentiationTimings {
  double assembly = 0.0;
  double analysis = 0.0;  // symbolic analysis (first Prepare only)
  double factorization = 0.0;
  double solve = 0.0;
  double accumulation = 0.0;
};

// Derivatives of the equilibrium x*(a) = argmin_x E(x, a) (fixed vertices held) by
// implicit differentiation. At an equilibrium, dE/dx = 0 on free DOFs, so with the
// exact stiffness K = d2E/dx2 (free DOFs) and B = d2E/(dx da):
//
//   dx*/da = -K^-1 B,     dL/da = -lambda^T B  with  K lambda = dL/dx.
//
// Built once per mesh and fixed-vertex set (the symbolic factorization is reused);
// then, per state: Prepare(x, a) assembles K at (x, a) and factorizes it (or, with
// options.reuse, defers that to the first adjoint solve), after which any number of
// gradients and Jacobian-vector products reuse that factorization. A factorization
// shared with a solver must not change between Prepare and those calls (a solve on it
// assembles and factorizes another state): they CHECK that it did not
// (StiffnessFactorization::generation()); Prepare again after such a solve.
// The model must outlive this object. Not thread-safe.
class EquilibriumDifferentiator {
 public:
  // Owns its StiffnessFactorization.
  EquilibriumDifferentiator(const ShapeTargetModel& model, const std::vector<bool>& fixed_mask,
                            const EquilibriumDifferentiatorOptions& options =
                                EquilibriumDifferentiatorOptions());
  // It keeps a reference to the model: a temporary one does not compile.
  EquilibriumDifferentiator(ShapeTargetModel&& model, const std::vector<bool>& fixed_mask,
                            const EquilibriumDifferentiatorOptions& options =
                                EquilibriumDifferentiatorOptions()) = delete;
  // Uses `factorization` (not owned; same model and fixed set), so that one CHOLMOD
  // factor serves Newton steps and gradients (memory: one factor instead of two).
  EquilibriumDifferentiator(StiffnessFactorization* factorization,
                            const EquilibriumDifferentiatorOptions& options =
                                EquilibriumDifferentiatorOptions());
  ~EquilibriumDifferentiator();

  // Assembles the exact K at positions x (3 x num_vertices, an equilibrium of a) and
  // factorizes it. Returns false with *error if K is not positive definite there
  // (naming the vertex where the factorization broke down: an unstable equilibrium,
  // or a body whose fixed vertices do not remove all rigid motions). With
  // options().reuse (max_iterations > 0) it only assembles K and returns true: whether K
  // is positive definite is found by the first adjoint solve (the bool overloads).
  // That x is an equilibrium is not checked (it costs an energy gradient): the
  // gradients are exact to the degree it is one. A bar whose largest force was 4e4
  // times the solve's tolerance (Prepare before Solve) gave a gradient 37% off; check
  // QuasistaticSolveReport::converged first. Finite differences to compare with need
  // re-solves tighter than their step: at the default tolerance 1e-6, a step of 1e-6
  // in a leaves the warm-started re-solve "already in equilibrium" (a zero difference).
  bool Prepare(const ShapeTargetModel::PositionsRef& x, const ShapeTargetModel::ActuationRef& a,
               std::string* error);

  // As Prepare, but factorizes K + relative_shift x mean(diag K) x I (relative_shift >
  // 0), never deferred: the regularized adjoint of a state whose exact K is singular or
  // not positive definite. The gradients that follow are those of the shifted system
  // (approximate, accurate where K's spectrum is far above the shift). false with
  // *error if even the shifted K cannot be factorized.
  bool PrepareShifted(const ShapeTargetModel::PositionsRef& x,
                      const ShapeTargetModel::ActuationRef& a, double relative_shift,
                      std::string* error);

  // The relative shifts the regularized adjoints try, from the first up by factors of
  // 100 to the last (PrepareExactOrShifted, training's adjoint).
  static constexpr double kFirstRelativeShift = 1e-10;
  static constexpr double kLastRelativeShift = 1e-4;

  // dL/da (6 x num_elements) for a loss L(x) whose gradient with respect to the
  // positions is dl_dx (3 x num_vertices; entries of fixed vertices are ignored since
  // fixed positions do not depend on a).
  ActuationMatrix LossGradient(const Eigen::Matrix3Xd& dl_dx);

  // Jacobian-vector products dx*/da [v] for k actuation directions at once:
  // directions is (6 num_elements) x k, each column an ActuationMatrix flattened
  // column-major (element e's six numbers at rows 6e .. 6e+5). Returns
  // (3 num_vertices) x k, each column a flattened 3 x num_vertices displacement
  // (zero on fixed vertices). Used with da/dz for latent Jacobians dx*/dz.
  Eigen::MatrixXd ActuationJacobianProduct(const Eigen::MatrixXd& directions);

  // Jacobian-vector products with respect to the prescribed positions of the fixed
  // vertices: for k motions of them (columns of `motion`, (3 num_vertices) x k; only the
  // rows of fixed vertices are read), the resulting change of the whole state,
  // (3 num_vertices) x k: the motion itself on fixed vertices and
  //   dx_free = -K^-1 K_free,fixed motion_fixed
  // on free ones (K_free,fixed from the exact dP/dF of the elements that touch fixed
  // vertices). Used to fit bone motions. Energy terms must not couple free and fixed
  // vertices (CHECKed: the factorization may have no energy terms).
  Eigen::MatrixXd FixedVertexJacobianProduct(const Eigen::MatrixXd& motion);

  // The adjoint solve alone: lambda = K^-1 g on free DOFs for g = dL/dx
  // (3 x num_vertices); returns 3 x num_vertices with zeros on fixed vertices.
  Eigen::Matrix3Xd SolveAdjoint(const Eigen::Matrix3Xd& dl_dx);
  // The same two with options().reuse (Prepare may have deferred the factorization):
  // false with *error if K is not positive definite (CG on an earlier factor met a
  // direction of non-positive curvature, or K had to be factorized and could not be).
  bool SolveAdjoint(const Eigen::Matrix3Xd& dl_dx, Eigen::Matrix3Xd* lambda, std::string* error);
  bool LossGradient(const Eigen::Matrix3Xd& dl_dx, ActuationMatrix* gradient, std::string* error);

  const ShapeTargetModel& model() const { return model_; }
  const EquilibriumDifferentiatorOptions& options() const { return options_; }
  const StiffnessFactorization& factorization() const { return *factorization_; }
  const DifferentiationTimings& timings() const { return timings_; }

 private:
  const ShapeTargetModel& model_;
  EquilibriumDifferentiatorOptions options_;
  std::unique_ptr<StiffnessFactorization> owned_factorization_;
  StiffnessFactorization* factorization_;
  Eigen::Matrix3Xd x_;
  ActuationMatrix a_;
  bool prepared_ = false;
  bool deferred_ = false;  // Prepare assembled K without factorizing it (options_.reuse)
  // factorization_->generation() as Prepare left it (or a deferred solve, which may
  // factorize the K Prepare assembled).
  int64_t generation_ = 0;
  // CHECKs that Prepare succeeded and the factorization has not changed since.
  void CheckPrepared() const;
  // Prepare and PrepareShifted: assembles the exact K at (x, a), then factorizes
  // K + relative_shift mean(diag K) I unless `defer`.
  bool PrepareAt(const ShapeTargetModel::PositionsRef& x, const ShapeTargetModel::ActuationRef& a,
                 bool defer, double relative_shift, std::string* error);
  // dL/da from the adjoint lambda (3 x num_vertices) at the prepared state.
  ActuationMatrix GradientFromAdjoint(const Eigen::Matrix3Xd& lambda);
  // The factorization's element SVDs if they are at the prepared state (x_, a_), else
  // nullptr (see PolarCache).
  const PolarCache* CacheAtState() const;
  DifferentiationTimings timings_;
};

// Prepare at (x, a) without deferring (the differentiator's options().reuse must be off,
// as for Jacobian products); where the exact K cannot be factorized, PrepareShifted with
// relative shifts kFirstRelativeShift, 100 times that, ... up to kLastRelativeShift, the
// first that factorizes. *shift: 0 (the exact K) or the shift used. false with *error
// (why the exact K failed) where none factorizes.
bool PrepareExactOrShifted(EquilibriumDifferentiator* differentiator,
                           const ShapeTargetModel::PositionsRef& x,
                           const ShapeTargetModel::ActuationRef& a, double* shift,
                           std::string* error);

}  // namespace aqs

#endif  // AQS_DIFF_EQUILIBRIUM_DIFFERENTIATOR_H_
