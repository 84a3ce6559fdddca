#ifndef AQS_EQUILIBRIUM_QUASISTATIC_SOLVER_H_
#define AQS_EQUILIBRIUM_QUASISTATIC_SOLVER_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "equilibrium/energy_term.h"
#include "equilibrium/stiffness_factorization.h"
#include "physics/actuation.h"
#include "physics/boundary_conditions.h"
#include "physics/shape_target_model.h"

namespace ceres {
class Problem;
}

namespace aqs {

// How Ceres solves the Gauss-Newton / Levenberg-Marquardt normal equations
// (SPARSE_NORMAL_CHOLESKY with SuiteSparse in all cases). Measured in docs/benchmarks.md.
enum class NormalEquationsOrdering {
  // Ceres' static sparsity with one ordering group per free vertex, in the
  // fill-reducing order CHOLMOD picks for the vertex graph (sparse/vertex_ordering.h):
  // symbolic analysis once per solver, METIS-quality fill, no per-iteration ordering.
  kVertexFillReducing,
  // dynamic_sparsity = true: CHOLMOD re-analyzes (orders) the Jacobian every iteration.
  kDynamic,
  // Ceres' default static path: Ceres orders parameter blocks itself (block AMD).
  kCeresDefault,
};

// How QuasistaticSolver::Solve minimizes the energy. Measured in docs/benchmarks.md.
enum class EquilibriumMethod {
  // Far from equilibrium, L-BFGS preconditioned by the rotation-fixed stiffness (one
  // factorization for the phase); then Newton's method with a line search on the energy
  // (equilibrium/newton_solver.h): steps on the PSD-projected stiffness, on the exact one
  // below newton_relative_force, handing back to L-BFGS where projected Newton steps
  // crawl (docs/solver.md). From rest, large poses take 2 to 4 factorizations, hard ones
  // (a bar curled to 1%, random indefinite targets) 7 to 16. Needs fixed vertices (a
  // free body's stiffness is singular) and energy terms that have a stiffness.
  kNewton,
  // Ceres' Levenberg-Marquardt on the least-squares form (one ShapeTargetCostFunction
  // per element), then exact Newton steps once the largest force is below
  // newton_relative_force. Works for free bodies and for energy terms without a
  // stiffness; converges linearly, and can crawl far from equilibrium.
  kLevenbergMarquardt,
};

struct QuasistaticSolverOptions {
  EquilibriumMethod method = EquilibriumMethod::kNewton;
  // Convergence: the largest residual force on a free vertex, |dE/dx_v|, is at most
  // relative_force_tolerance * model.force_scale() (the nodal force of an element
  // under unit strain). 1e-6 means equilibrium to about 1e-6 strain.
  //
  // Below ~1e-9 the test meets the floating-point floor of least squares (with
  // kLevenbergMarquardt): the cost changes of such small steps are round-off (~10 eps
  // of E), so Ceres can no longer tell good steps from bad. Newton steps decide on the
  // force there and reach ~1e-13.
  double relative_force_tolerance = 1e-6;
  // Iterations at most: stiffness factorizations (kNewton), or Ceres iterations
  // (successful and rejected steps) plus Newton factorizations (kLevenbergMarquardt).
  int max_iterations = 200;
  // kNewton: preconditioned L-BFGS iterations at most, far from equilibrium (each one
  // solve with a factorization kept across solves; no factorization of its own).
  int max_lbfgs_iterations = 500;
  // kNewton: precondition L-BFGS with the factor this solver's stiffness factorization
  // holds from an earlier state (a Newton step's) instead of building a factor of the
  // rotation-fixed stiffness of its own: no second factor per solver (at 232,635
  // elements 0.27 GB) and no factorization for it. If that factor is marked for
  // refreshing (aged: StiffnessFactorization::refresh_requested), Newton starts at once;
  // without any (a first solve) the rotation-fixed factor is built for that solve and
  // released after it. For solvers that keep one pose's factor across solves.
  bool lbfgs_reuses_factor = false;
  // With lbfgs_reuses_factor: Newton takes over from L-BFGS on the earlier factor once
  // its largest force has not halved in this many iterations
  // (PreconditionedLbfgsOptions::stall_iterations; 0: never). The factor is the exact
  // stiffness of a nearby state, so L-BFGS on it converges in a few steps (621 of the
  // 630 phases in the traces of 240K-element face training took 1 to 16) unless it no
  // longer fits the state: there one phase ran 500 iterations (24 minutes) from a force
  // 5x Newton's threshold, where Newton then needed 3 factorizations (docs/scale.md).
  // The rotation-fixed preconditioner has no stall test: on rotation-dominated motion
  // from rest the largest force rises and falls while the body swings, yet L-BFGS
  // converges (the 40 x 4 x 4 bar's curl: 137 iterations and 3 factorizations; a stall
  // test at 30 would hand over after 42, and Newton then took 91 factorizations).
  int lbfgs_reused_factor_stall_iterations = 20;
  // Threads for energy, stiffness and residual/Jacobian evaluation (CHOLMOD's BLAS
  // threads are set by OPENBLAS_NUM_THREADS).
  int num_threads = 2;
  // Newton's steps along negative curvature where the exact stiffness stays indefinite
  // (NewtonSolverOptions::negative_curvature_steps). Off by default: they leave saddles
  // in a few factorizations where projected steps take tens or fail (tests/equilibrium),
  // but in 240K-element face training they cost more than they saved (docs/scale.md).
  bool negative_curvature_steps = false;
  // Newton's stall rule (NewtonSolverOptions::stall_steps): a Newton phase stops, not
  // converged (QuasistaticSolveReport::newton_stalled), after this many backtracked steps
  // without progress, as at a kink of the energy (a contact's closest feature switching);
  // 0: never (its factorization budget alone ends such a phase).
  static constexpr int kDefaultNewtonStallSteps = 16;
  int newton_stall_steps = kDefaultNewtonStallSteps;
  // After a converged solve (with fixed vertices and every term's stiffness), check that
  // the equilibrium is stable: one factorization of the exact stiffness there, which
  // fails where K is not positive definite (a saddle: zero force, yet not a rest state;
  // exact steps by CG on an earlier factor can converge to one). From a saddle the solve
  // leaves by LeaveUnstableEquilibrium and checks again, at most
  // kMaxStabilityEscapes times; QuasistaticSolveReport::stable says how it ended. Off by
  // default: training checks every equilibrium in its adjoint instead, at no extra
  // factorization; aqs_simulate turns it on (--ensure_stable).
  bool ensure_stable = false;
  // Print Ceres' per-iteration progress lines to stdout (kLevenbergMarquardt).
  bool log_progress = false;
  // Ordering of Ceres' normal equations (see NormalEquationsOrdering).
  NormalEquationsOrdering ordering = NormalEquationsOrdering::kVertexFillReducing;
  // Ceres' use_postordering (static orderings only).
  bool use_postordering = false;
  // Exact stiffness near equilibrium: once the largest force is below
  // newton_relative_force x force_scale, steps use the exact stiffness, which converges
  // quadratically (Levenberg-Marquardt's J^T J lacks the curvature of incompatible
  // targets and converges linearly). kNewton: above it steps use the projected
  // stiffness; 0 means projected steps only. kLevenbergMarquardt: Ceres runs down to
  // it, then Newton; 0 means Ceres only. Contact solves (lib/contact) use 0.1.
  double newton_relative_force = 1e-2;
  // Exact Newton steps (kNewton) first try conjugate gradients preconditioned by the
  // factor of an earlier state (see NewtonSolverOptions::reuse): a warm re-solve after a
  // small change of the actuation then needs no factorization. max_iterations = 0: off.
  FactorReuseOptions factor_reuse = {20, 1e-6, 6, 1e-2, 1, 8};
  // Ceres' relative cost-change and step-size stopping tests. function_tolerance
  // 1e-15 stops only at the round-off floor of the cost (where further iterations
  // are noise); the force test above decides whether the result counts as converged.
  double function_tolerance = 1e-15;
  double parameter_tolerance = 1e-14;

  // Checks every field; false with *error naming the first bad one (by field name).
  bool Validate(std::string* error) const;
  // What shapes a solve's result, as one line of text: every field but num_threads and
  // log_progress, doubles exactly (the keys of stored results: prepare's targets, the
  // evaluation's fits). A new field that changes results belongs here; newton_stall_steps
  // is written only where it is not kDefaultNewtonStallSteps (the rule's length since
  // before it was an option), so keys stored before it still match.
  std::string KeyText() const;
};

struct QuasistaticSolveReport {
  // final_max_force <= force_tolerance.
  bool converged = false;
  // Levenberg-Marquardt iterations (Ceres, after its initial evaluation) plus stiffness
  // factorizations (lm_iterations + factorizations; Newton steps by CG on an earlier
  // factor are not counted); and how many LM steps were accepted.
  int iterations = 0;
  int lm_iterations = 0;
  int successful_iterations = 0;
  // kNewton far from equilibrium: preconditioned L-BFGS iterations (one solve with the
  // rotation-fixed stiffness each; equilibrium/preconditioned_lbfgs.h).
  int lbfgs_iterations = 0;
  bool lbfgs_stalled = false;  // Newton took over from a stalled L-BFGS phase
  // kNewton: how often Newton's projected steps handed back to L-BFGS (at most
  // QuasistaticSolver::kMaxNewtonHandBacks).
  int newton_hand_backs = 0;
  // A Newton phase stopped by its stall rule (the solve may still converge after it, as
  // in EnsureStable's descent from a perturbed state).
  bool newton_stalled = false;
  // Newton steps taken (projected + exact), and the stiffness factorizations of the
  // solve: Newton's (a step whose exact stiffness is rejected, or that needs a shift,
  // factorizes more than once) plus the L-BFGS preconditioner's, when it had to be
  // (re)built (once per solver while its energy terms have constant Hessians).
  int newton_steps = 0;
  int projected_steps = 0;
  int exact_steps = 0;
  int reused_steps = 0;  // exact steps solved by CG on an earlier factor (no factorization)
  int factorizations = 0;
  int shifted_factorizations = 0;
  int line_search_evaluations = 0;
  // QuasistaticSolverOptions::ensure_stable: whether the final state was checked, what
  // the check found (the exact K positive definite there), and how many saddles the
  // solve left on the way. The checks' factorizations count in `factorizations`.
  bool stability_checked = false;
  bool stable = false;
  int unstable_escapes = 0;
  double initial_energy = 0.0;
  double final_energy = 0.0;
  // Largest force norm |dE/dx_v| over free vertices, before and after.
  double initial_max_force = 0.0;
  double final_max_force = 0.0;
  double force_tolerance = 0.0;
  // Why the solve stopped (Ceres' termination message, Newton's, or why neither ran).
  std::string termination;
  // The solve could not start: a non-finite actuation or fixed position, a free body
  // for kNewton (termination says which; "refused: ..."). Nothing ran, and the
  // energies and forces above are 0.
  bool refused = false;
  double seconds = 0.0;
  // Ceres' own accounting (0 if Ceres did not run): problem preparation, and the
  // minimizer's time with its residual/Jacobian evaluation and linear-solver parts.
  double ceres_preprocessor_seconds = 0.0;
  double ceres_minimizer_seconds = 0.0;
  double ceres_evaluation_seconds = 0.0;
  double ceres_linear_solver_seconds = 0.0;

  // The path the solve took, e.g. "Newton: 9 projected + 3 exact steps, 12
  // factorizations" or "LM 25 iterations (20 accepted) + Newton: 2 exact steps, 2
  // factorizations".
  std::string Path() const;
  // One line: converged/NOT CONVERGED, path, energies, forces, reason, time.
  std::string Summary() const;
};

// The solver's actuation (QuasistaticSolver::actuation()): an Eigen::Map of its storage,
// 6 x num_elements (column e is element e's 6 shape-target entries), whose assignment
// from a whole matrix CHECKs that the sizes agree. (A plain Map cannot resize, and
// under NDEBUG Eigen does not check: an actuation of another mesh was read past its
// end, or written past the solver's storage.) Blocks, columns and coefficients are
// the Map's own.
class ActuationView : public Eigen::Map<ActuationMatrix> {
 public:
  using Base = Eigen::Map<ActuationMatrix>;
  ActuationView(double* data, Eigen::Index num_elements) : Base(data, 6, num_elements) {}
  ActuationView(const ActuationView&) = default;
  ActuationView& operator=(const ActuationView& other) {
    CheckAssignedSize(other.rows(), other.cols());
    Base::operator=(other);
    return *this;
  }
  template <typename Derived>
  ActuationView& operator=(const Eigen::DenseBase<Derived>& other) {
    CheckAssignedSize(other.rows(), other.cols());
    Base::operator=(other);
    return *this;
  }

 private:
  void CheckAssignedSize(Eigen::Index rows, Eigen::Index cols) const;
};

// Finds the quasistatic equilibrium x*(a) = argmin_x E(x, a) of a ShapeTargetModel
// under fixed vertices, by options().method: preconditioned L-BFGS and Newton steps on
// CHOLMOD factorizations (kNewton, the default), or as a Ceres nonlinear least-squares
// problem made of one ShapeTargetCostFunction per element (kLevenbergMarquardt).
//
// Built once per mesh and boundary-condition set; then, between solves, the
// actuation is changed in place (actuation()), prescribed positions moved
// (SetFixedPositions) and the state warm-started (SetPositions); each Solve() starts
// from the current state and leaves the result in positions().
//
//   QuasistaticSolver solver(model, bc, options);
//   solver.actuation() = a;
//   QuasistaticSolveReport report = solver.Solve();
//   if (!report.converged) ...;  // report.Summary() says why
//   use(solver.positions());
//
// The model must outlive the solver. Not thread-safe; use one solver per thread.
class QuasistaticSolver {
 public:
  // QuasistaticSolverOptions::ensure_stable: saddles left at most this many times per
  // solve, each by a perturbation of kStabilityEscapeSize mean rest edge lengths.
  static constexpr int kMaxStabilityEscapes = 3;
  static constexpr double kStabilityEscapeSize = 1e-2;
  // The relative shift (of mean(diag K)) under which a K that is singular but not
  // indefinite factorizes: the stability check's second try, and the L-BFGS
  // preconditioner's (a mesh piece that nothing holds makes every K singular).
  static constexpr double kSingularShift = 1e-10;
  // kNewton's hand-backs (Solve): after this many projected Newton steps, L-BFGS takes
  // over again down to kLbfgsHandBackFactor of the force, at most kMaxNewtonHandBacks
  // times in a solve (then Newton goes on to the end). Measured in docs/solver.md.
  static constexpr int kProjectedStepsBeforeLbfgs = 4;
  static constexpr double kLbfgsHandBackFactor = 1e-2;
  static constexpr int kMaxNewtonHandBacks = 3;

  // options must be valid (Validate) and bc valid for the model
  // (ValidateBoundaryConditions): both CHECKed.
  // The initial state is the rest shape with fixed vertices at their prescribed
  // positions, and the actuation is S = I.
  QuasistaticSolver(const ShapeTargetModel& model, const BoundaryConditions& bc,
                    const QuasistaticSolverOptions& options = QuasistaticSolverOptions());
  // The solver keeps a reference to the model: a temporary one does not compile.
  QuasistaticSolver(ShapeTargetModel&& model, const BoundaryConditions& bc,
                    const QuasistaticSolverOptions& options = QuasistaticSolverOptions()) =
      delete;
  ~QuasistaticSolver();
  QuasistaticSolver(const QuasistaticSolver&) = delete;
  QuasistaticSolver& operator=(const QuasistaticSolver&) = delete;

  const ShapeTargetModel& model() const { return model_; }
  const QuasistaticSolverOptions& options() const { return options_; }
  // options must be valid (CHECK: Validate), as in the constructor.
  void set_options(const QuasistaticSolverOptions& options);

  // Per-element actuation (6 x num_elements), read by every evaluation: change it in
  // place between solves (solver.actuation() = a; solver.actuation().col(e) = ...).
  // It is a view of storage the solver owns: assigning a whole matrix copies into it,
  // and CHECKs that it is 6 x num_elements (ActuationView).
  ActuationView actuation() { return ActuationView(actuation_.data(), model_.num_elements()); }
  Eigen::Map<const ActuationMatrix> actuation() const {
    return Eigen::Map<const ActuationMatrix>(actuation_.data(), 6, model_.num_elements());
  }

  // Current state (3 x num_vertices): the last solution or the warm start.
  Eigen::Map<const Eigen::Matrix3Xd> positions() const {
    return Eigen::Map<const Eigen::Matrix3Xd>(positions_.data(), 3, model_.num_vertices());
  }
  // Sets the warm start. Fixed vertices are reset to their prescribed positions.
  void SetPositions(const Eigen::Matrix3Xd& positions);
  // Moves every free vertex of the state by a deterministic pseudo-random displacement,
  // each coordinate uniform in [-1, 1] x relative_size x the mesh's mean rest edge
  // length (a generator seeded by `seed`). For leaving an unstable equilibrium (a
  // saddle: zero force, but an exact stiffness that is not positive definite), from
  // which Solve() then descends to a stable one.
  void PerturbFreeVertices(double relative_size, unsigned seed);
  // New prescribed positions of the fixed vertices (3 x bc.vertices.size(), in the
  // order of bc.vertices); applied to the state immediately. Non-finite ones are taken,
  // and Solve() refuses them (report.refused, naming the vertex).
  void SetFixedPositions(const Eigen::Matrix3Xd& fixed_positions);

  const std::vector<int>& fixed_vertices() const { return fixed_vertices_; }
  const Eigen::Matrix3Xd& fixed_positions() const { return fixed_positions_; }
  // true for fixed vertices (num_vertices entries).
  const std::vector<bool>& fixed_mask() const { return fixed_mask_; }

  // Adds an energy term (not owned; must outlive the solver) to the equilibrium:
  // the solver then minimizes E(x, a) + the terms. Call before Solve(), and before
  // taking stiffness_factorization(): a term with vertex couplings replaces it (CHECK:
  // not once stiffness_factorization() has handed it out, whose holder would be left
  // with a freed factor).
  void AddEnergyTerm(const EnergyTerm* term);
  const std::vector<const EnergyTerm*>& energy_terms() const { return terms_; }

  // Leaves an unstable equilibrium (zero force, but an exact stiffness that is not
  // positive definite: a saddle of the energy, which an adjoint cannot use and a pose
  // would not keep): PerturbFreeVertices(relative_size, seed), then Newton steps on the
  // PSD-projected stiffness only, down to the force tolerance (exact Newton steps would
  // be drawn back to the saddle). Bodies without fixed vertices, or energy terms
  // without a stiffness, are refused (converged = false, termination says why).
  QuasistaticSolveReport LeaveUnstableEquilibrium(double relative_size, unsigned seed);

  // Minimizes E(., actuation()) (plus energy terms) from positions() by
  // options().method. Returns what happened; a solve that does not reach the force
  // tolerance says so (converged = false), as does one refused before it starts
  // (report.refused: non-finite actuations or prescribed positions; kNewton on a body
  // without fixed vertices).
  QuasistaticSolveReport Solve();

  // Largest |dE/dx_v| over free vertices at the current state (and E through *energy;
  // both include the energy terms).
  double MaxFreeForce(double* energy = nullptr) const;
  // The absolute force tolerance: relative_force_tolerance * model.force_scale().
  double ForceTolerance() const;

  // The stiffness factorization the Newton steps use (created on first use, its pattern
  // with the energy terms' couplings), to share with an EquilibriumDifferentiator so
  // that one CHOLMOD factor serves both.
  // Once handed out, AddEnergyTerm CHECKs that no term with vertex couplings replaces it.
  StiffnessFactorization* stiffness_factorization();
  // Whether the solver holds a factor of the rotation-fixed stiffness for its L-BFGS
  // phase between solves (never with lbfgs_reuses_factor).
  bool holds_lbfgs_preconditioner() const { return preconditioner_ != nullptr; }

 private:
  void ApplyFixedPositions();
  // The Ceres problem (built on first use: only Levenberg-Marquardt needs it).
  ceres::Problem* problem();
  // Runs Ceres from the current state to the absolute force `tolerance`.
  void RunCeres(double tolerance, QuasistaticSolveReport* report);
  // Newton steps (MinimizeEnergyNewton) from the current state, exact stiffness below
  // the absolute force `exact_threshold`; true if the force tolerance was reached.
  // hand_back_after > 0: Newton stops after that many projected steps (report->
  // newton_hand_backs counts it), for L-BFGS to take over.
  bool RunNewton(double exact_threshold, QuasistaticSolveReport* report,
                 int hand_back_after = 0);
  // Preconditioned L-BFGS from the current state down to the absolute force
  // `tolerance` (builds or refreshes the preconditioner as needed).
  void RunLbfgs(double tolerance, QuasistaticSolveReport* report);
  // The L-BFGS phase with this factorization's current factor as the preconditioner,
  // stopped after `stall_iterations` without a halving of the force (0: never).
  void RunLbfgsWith(StiffnessFactorization* preconditioner, double tolerance,
                    int stall_iterations, QuasistaticSolveReport* report);
  // options_.ensure_stable after a converged solve: factorizes the exact K at the final
  // state, and where that fails K + kSingularShift mean(diag K) I (which factorizes where
  // K is only singular, as with a mesh piece nothing holds: stable, not a saddle); from a
  // saddle leaves (perturbation and projected Newton steps) and checks
  // again, at most kMaxStabilityEscapes times. Sets report->stability_checked, stable
  // and unstable_escapes; if a descent from a saddle fails, the saddle stays the result.
  void EnsureStable(QuasistaticSolveReport* report);
  // After PerturbFreeVertices, with report->final_max_force that of the perturbed state:
  // projected Newton steps down to the force tolerance (LeaveUnstableEquilibrium,
  // EnsureStable). True if it is reached.
  bool DescendFromPerturbedState(QuasistaticSolveReport* report);
  // Why this solve cannot start (empty if it can): non-finite actuations, a free body
  // for kNewton.
  std::string RefusalReason() const;
  // Whether Newton's method applies: some vertices are fixed (so K can be positive
  // definite) and every energy term supplies its stiffness.
  bool NewtonApplies() const;
  double* vertex(int v) { return positions_.data() + 3 * static_cast<size_t>(v); }
  // The factorization, created on first use, for the solver's own solves (not marked
  // as handed out).
  StiffnessFactorization* OwnFactorization();

  const ShapeTargetModel& model_;
  QuasistaticSolverOptions options_;
  std::vector<int> fixed_vertices_;
  Eigen::Matrix3Xd fixed_positions_;
  std::vector<bool> fixed_mask_;
  // Fixed-size storage that Ceres' cost functions and parameter blocks point into:
  // never reallocated, only written through.
  std::vector<double> actuation_;
  std::vector<double> positions_;
  std::unique_ptr<ceres::Problem> problem_;
  std::unique_ptr<StiffnessFactorization> factorization_;
  bool factorization_handed_out_ = false;  // stiffness_factorization() was called
  // The rotation-fixed stiffness, factorized, preconditioning L-BFGS (kNewton far from
  // equilibrium); kept across solves while every energy term's Hessian is constant.
  std::unique_ptr<StiffnessFactorization> preconditioner_;
  bool preconditioner_current_ = false;
  std::vector<const EnergyTerm*> terms_;
  // Free vertices in fill-reducing order (computed on the first Solve that needs it).
  std::vector<int> vertex_order_;
};

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_QUASISTATIC_SOLVER_H_
