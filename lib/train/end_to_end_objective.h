#ifndef AQS_TRAIN_END_TO_END_OBJECTIVE_H_
#define AQS_TRAIN_END_TO_END_OBJECTIVE_H_

#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <ceres/first_order_function.h>
#include <Eigen/Core>

#include "diff/equilibrium_differentiator.h"
#include "dist/communicator.h"
#include "equilibrium/quasistatic_solver.h"
#include "model/active_model.h"
#include "train/evaluation_counters.h"
#include "train/latent_refit.h"
#include "train/trainer.h"
#include "util/wall_timer.h"

namespace aqs {

struct PointOnLine;

// The end-to-end training objective (see TrainEndToEnd) as a Ceres FirstOrderFunction
// over the flat vector [decoder params (num_parameters); z_1; ...; z_P (latent_dim each)]:
//
//   L = (1/(P N)) sum_p sum_i |p_i(x*(a(z_p))) - y_pi|^2 + lambda (1/P) sum_p |z_p|^2
//       + decoder_regularization |params|^2
//       + energy_regularization (1/P) sum_p E(x*_p, a_p) / (sum_e mu_e V_e)
//
// (the terms of TrainOptions). Evaluate() decodes all poses, solves their equilibria in
// parallel (a solver per pose while the factors fit TrainOptions::max_factor_cache_gb,
// else per thread; warm-started from each pose's last state) and, with a gradient, runs
// one adjoint solve per pose and back-propagates through the embedding and the decoder.
// It returns false (a failed step for Ceres, which then shortens the line-search step)
// if an equilibrium cannot be reached, if the loss is not finite, if an adjoint cannot
// be solved even with the shifted stiffness (an equilibrium whose exact stiffness is not
// positive definite is first left by a perturbation, kMaxEscapes times, then takes the
// adjoint of K + shift I: kFirstAdjointShift...), or once a time limit has passed. A
// pose whose warm start fails is retried from the rest shape only until it has
// converged once: afterwards a failure is a step too long for the
// branch training follows (retrying from rest would cost a long solve and could jump
// to another branch of the non-convex energy). Not thread-safe (Ceres calls it from
// one thread).
//
// Distributed (TrainOptions::communicator with more than one rank; docs/distributed.md):
// every rank constructs the objective from the same model; rank r owns the poses p
// with p % size == r (OwnedIndices) and keeps their solvers and warm starts. Rank 0
// alone is called by Ceres: each of its calls to Evaluate, UseStatesOf,
// AllowRetryFromRest and CollectStates first sends the command (and the parameters)
// to the other ranks, which wait in Serve() and carry it out on their poses. An
// evaluation decodes and solves each rank's own poses, back-propagates them through
// the decoder, and sums cost and gradient on rank 0 (the per-pose losses exactly, the
// decoder gradient to round-off); a failing pose fails the evaluation on rank 0 with
// its name and reason, as in one process. Ranks without poses take part with zeros.
// Rank 0 ends Serve() on the others with StopWorkers (or its destructor).
class EndToEndObjective final : public ceres::FirstOrderFunction {
 public:
  // The model (pre-trained: decoder set) must outlive the objective; its states seed
  // the warm starts.
  EndToEndObjective(const TrainOptions& options, const ActiveModel& model);
  // On rank 0 of a distributed run, stops the other ranks (StopWorkers(false)) unless
  // StopWorkers was called.
  ~EndToEndObjective() override;

  int NumParameters() const override;
  // Rank 0 only (in a distributed run: collective with the others' Serve()).
  bool Evaluate(const double* parameters, double* cost, double* gradient) const override;

  // Ranks other than 0 of a distributed run: carries out rank 0's commands until it
  // stops them; returns the status rank 0 passed to StopWorkers. `model` is this rank's
  // copy of the model, which latent refits (RefitLatents) write into; without it (null)
  // rank 0 must not command refits.
  bool Serve(ActiveModel* model = nullptr);
  // Rank 0: ends the other ranks' Serve() with `ok` (once; later calls do nothing).
  void StopWorkers(bool ok);
  // Whether this objective spans several ranks, and the poses this rank owns.
  bool distributed() const { return size_ > 1; }
  const std::vector<int>& owned_poses() const { return owned_; }

  // Evaluate() fails at once once this many seconds have passed from this call (0:
  // never), so that a line search overruns a training budget by one evaluation at most.
  void set_time_limit(double seconds) {
    deadline_ = seconds > 0.0 ? timer_.Seconds() + seconds : 0.0;
  }

  // Lets the next evaluation retry every pose from rest again if its warm start fails
  // (for a final evaluation, which must not fail where a line-search trial may).
  void AllowRetryFromRest();

  // The model's current [params; latents] as a flat vector.
  Eigen::VectorXd ModelParameters() const;

  // At the last evaluated point: surface errors (mean and max distance over poses and
  // surface vertices; on rank 0), the per-pose equilibria (of this rank's poses), and
  // why an evaluation failed.
  double mean_surface_error() const;
  double max_surface_error() const;
  const std::vector<Eigen::Matrix3Xd>& states() const { return states_; }

  // The per-pose equilibria of one of the last kRememberedEvaluations successful
  // evaluations, found by the exact parameter vector (NumParameters() values): a line
  // search evaluates trial points after the one it accepts, and with a non-convex energy
  // the equilibria of the accepted point are the ones to save and to restart from.
  // StatesAt returns false if no remembered evaluation was at these parameters;
  // UseStatesOf makes them the warm starts of the next evaluation.
  static constexpr int kRememberedEvaluations = 3;
  // Unstable equilibria (exact stiffness not positive definite) are left at most this
  // many times per pose and evaluation, each by a perturbation of this size relative to
  // the mean rest edge length (QuasistaticSolver::LeaveUnstableEquilibrium).
  static constexpr int kMaxEscapes = 1;
  static constexpr double kEscapeRelativeSize = 1e-2;
  // Then the adjoint of K + shift mean(diag K) I, shifts from the first to the last by
  // factors of 100 (EquilibriumDifferentiator::PrepareShifted).
  static constexpr double kFirstAdjointShift = EquilibriumDifferentiator::kFirstRelativeShift;
  static constexpr double kLastAdjointShift = EquilibriumDifferentiator::kLastRelativeShift;
  // Both are local to this rank (StatesAt: its own poses' states); UseStatesOf, on rank
  // 0, also commands the other ranks to use theirs.
  bool StatesAt(const double* parameters, std::vector<Eigen::Matrix3Xd>* states) const;
  bool UseStatesOf(const double* parameters);
  // Keeps the remembered evaluation at `parameters` (the point a line search has just
  // accepted: the trainer calls this at every iteration; one of the last
  // kRememberedEvaluations or the one of the lowest loss since the last call) apart
  // from the others, until the next call, so that StatesAt, UseStatesOf and
  // CollectStates find its equilibria however many trial points a line search evaluates
  // after it (a failed line search, and the restart or final evaluation after it), and
  // rather than those of a later evaluation at the same point (which started elsewhere
  // and may have reached another equilibrium).
  // Returns false, keeping nothing, if no remembered evaluation was at `parameters`.
  // Rank 0 only: it commands the other ranks to keep theirs.
  bool KeepStatesOf(const double* parameters);
  // The surface errors (as mean_surface_error(), max_surface_error(); rank 0) of the
  // evaluation KeepStatesOf kept, which may not be the last one evaluated; false (and
  // nothing set) if none is kept.
  bool KeptSurfaceErrors(double* mean, double* max) const;
  // A round of latent refits at `parameters` (RefitTrainingLatents with the decoder
  // fixed, TrainOptions' latent_refit_iterations and regularization): every rank refits
  // the poses it owns, from their equilibria at `parameters` (the remembered evaluation
  // there, else the last ones), and keeps the refitted equilibria as their warm starts.
  // `model` (this rank's copy) receives the parameters' decoder and latents and the
  // refits' latents and states of the owned poses. On rank 0 the latents in
  // `parameters` become the refitted ones of every pose, and the report sums the ranks'
  // (seconds: rank 0's wall time). Rank 0 only (collective with the others' Serve).
  LatentRefitReport RefitLatents(ActiveModel* model, double* parameters);
  // Rank 0: every pose's equilibrium at `parameters` (those of the remembered
  // evaluation there, else the last ones), gathered from the ranks that own them: what
  // a checkpoint saves. One process: StatesAt, else states().
  void CollectStates(const double* parameters, std::vector<Eigen::Matrix3Xd>* states) const;
  // Why the last evaluation failed; empty if it succeeded (a failure of an earlier one
  // does not name the cause of a later stop).
  const std::string& last_failure() const { return last_failure_; }

  // What the last evaluation cost (summed over its poses, of all ranks), and all
  // evaluations so far (on rank 0).
  using Counters = EvaluationCounters;
  const Counters& last_counters() const { return last_counters_; }
  const Counters& total_counters() const { return total_counters_; }
  // Whether each pose has its own solver and factor (TrainOptions::max_factor_cache_gb),
  // and the size of one solver's factor that choice was made on (GB: the numeric
  // factor's storage from CHOLMOD's symbolic analysis, SparseCholesky::factor_bytes, plus
  // the element SVD cache, PolarCache::BytesFor; 0 on a rank without poses). A solver per
  // pose keeps no second factor: its L-BFGS phase reuses its own
  // (QuasistaticSolverOptions::lbfgs_reuses_factor).
  bool solver_per_pose() const { return solver_per_pose_; }
  double factor_gb() const { return factor_gb_; }
  // With solvers per thread: how many of this rank's poses keep their factor in single
  // precision between evaluations (the first ones owned), and one such copy's size, GB.
  int num_stored_factors() const { return num_stored_factors_; }
  double stored_factor_gb() const { return stored_factor_gb_; }

 private:
  struct Worker {
    std::unique_ptr<QuasistaticSolver> solver;
    std::unique_ptr<EquilibriumDifferentiator> differentiator;
  };

  enum Command : int {
    kEvaluate = 1,
    kEvaluateWithGradient,
    kUseStatesOf,
    kAllowRetryFromRest,
    kCollectStates,
    kRefitLatents,
    kKeepStates,
    kStop,
  };
  // Rank 0: sends a command (with `value`: the status of kStop) and, for commands that
  // take them, the parameters to the other ranks.
  void SendCommand(Command command, const double* parameters, int value = 0) const;
  // The evaluation on this rank's poses and the reductions (collective when
  // distributed). cost and gradient receive the totals on rank 0.
  bool EvaluateHere(const double* parameters, double* cost, double* gradient) const;
  // EvaluateHere's parts. On owned pose k (pose p = owned_[k]) with the worker of
  // thread t (its own with a solver per pose) and actuation a (6 x num_elements):
  // EvaluatePose solves the equilibrium (solved: 3 x num_vertices), records the pose's
  // loss and errors and, with_gradient, its dL_p/da (dl_da: 6 x num_elements); a failure
  // is left in failures_[p]. `line`: a line-search trial's line (null: none). It adds
  // the pose's work to `counters`.
  void EvaluatePose(int k, int t, const ActuationMatrix& a, const PointOnLine* line,
                    bool with_gradient, Eigen::Matrix3Xd* solved, ActuationMatrix* dl_da,
                    Counters* counters) const;
  // Sets the worker's solver to pose k's fixed positions, actuation a and warm start, and
  // its factor (the pose's stored one, else a refresh); returns how the solve starts,
  // for the per-pose trace.
  const char* StartPose(int k, const ActuationMatrix& a, Worker* w) const;
  // From the converged solve in w: the equilibrium (solved), the loss (RecordPoseLoss)
  // and, with_gradient, dL_p/da by the adjoint, leaving an unstable equilibrium or
  // shifting the stiffness where K is not positive definite. Returns false with
  // failures_[p] set. `trace` receives the adjoint's CG counts (with_gradient).
  struct AdjointTrace {
    int reused = 0;      // adjoints solved by CG on an earlier factor
    int indefinite = 0;  // CG solves that found K indefinite
  };
  bool PoseGradient(int p, const ActuationMatrix& a, bool with_gradient, Worker* w,
                    Eigen::Matrix3Xd* solved, ActuationMatrix* dl_da, Counters* counters,
                    AdjointTrace* trace) const;
  // pose_loss_[p], pose_mean_[p], pose_max_[p] at equilibrium x (3 x num_vertices);
  // diff: the embedded surface minus the pose's (3 x num_surface_vertices); energy_da:
  // dE/da at x when energy_regularization > 0 (else untouched).
  void RecordPoseLoss(int p, const Eigen::Matrix3Xd& x, const ActuationMatrix& a, Worker* w,
                      Eigen::Matrix3Xd* diff, ActuationMatrix* energy_da) const;
  // The data term's factor 1/(P N) and the energy regularizer's (1/P) lambda_E /
  // sum_e mu_e V_e.
  double LossScale() const;
  double EnergyScale() const;
  // Distributed: every pose's loss, mean and max error summed onto rank 0 (collective).
  void GatherPoseErrorsToRoot() const;
  // The gradient (NumParameters()) on rank 0: the owned poses' dL/da back through the
  // decoder (summed over ranks; collective when distributed), plus the regularizers'.
  void BackPropagate(const double* parameters, const DecoderWorkspace& workspace,
                     const std::vector<ActuationMatrix>& dl_da, double* gradient) const;
  void CollectStatesHere(const double* parameters, std::vector<Eigen::Matrix3Xd>* states) const;
  LatentRefitReport RefitHere(ActiveModel* model, double* parameters);

  const TrainOptions options_;
  const ActiveModel& model_;
  const Communicator* communicator_;  // null: one process
  int rank_ = 0, size_ = 1;
  std::vector<int> owned_;  // poses of this rank, ascending
  bool stopped_ = false;    // rank 0: StopWorkers was called
  const ShapeTargetModel physics_;
  const int num_params_, latent_dim_, num_poses_;
  std::vector<Eigen::Matrix3Xd> fixed_positions_;
  // Evaluation is logically const for Ceres; these caches change.
  mutable std::vector<Worker> workers_;  // one per owned pose, or one per thread
  bool solver_per_pose_ = false;
  double factor_gb_ = 0.0;
  int num_stored_factors_ = 0;
  double stored_factor_gb_ = 0.0;
  // With solvers per thread: owned pose k's last factor, for k < num_stored_factors_
  // (empty until its first evaluation, or after one that failed).
  mutable std::vector<StoredStiffnessFactor> stored_factors_;
  mutable Counters last_counters_, total_counters_;
  mutable std::vector<Eigen::Matrix3Xd> states_;
  // With a solver per pose or a stored factor: the actuation each state is the
  // equilibrium of (empty: not known), for the first-order prediction of the next
  // evaluation's start.
  mutable std::vector<ActuationMatrix> state_actuations_;
  // Moves pose p's solver from states_[p] to x + dx*/da (a - a_state), the equilibrium
  // predicted to first order for the solver's new actuation a, using the pose's last
  // factor; keeps the warm start where the prediction does not lower the largest force.
  void PredictState(int p, Worker* worker) const;
  // For a line-search trial (FindPointOnLine): `from` and `to` are a pose's equilibria
  // at the two evaluations whose line holds this one, and `last` the one its warm start
  // came from. Offers the worker's solver (its actuation set, at that warm start) two
  // more starts, from + t (to - from) and, where `last` is one of the two, the quadratic
  // through both with the warm start's first-order slope; keeps whichever start has the
  // lowest largest force. Returns whether the solver moved.
  bool StartOnLine(const Eigen::Matrix3Xd& from, const Eigen::Matrix3Xd& to, double t,
                   const Eigen::Matrix3Xd& last, Worker* worker) const;
  mutable std::vector<double> pose_loss_, pose_mean_, pose_max_;
  mutable std::vector<std::string> failures_;
  mutable std::vector<char> converged_once_;  // per pose, in this objective's life
  // Per pose: the relative shift its last adjoint needed (0: none, the exact K).
  mutable std::vector<double> adjoint_shift_;
  struct Remembered {
    Eigen::VectorXd parameters;  // NumParameters(), compared bit for bit
    std::vector<Eigen::Matrix3Xd> states;
    // Its surface errors (mean_surface_error(), max_surface_error(); rank 0's).
    double mean_surface_error = 0.0;
    double max_surface_error = 0.0;
  };
  mutable std::vector<Remembered> remembered_;  // newest last
  Remembered kept_;  // KeepStatesOf's (empty parameters: none)
  // The successful evaluation of the lowest loss since the last KeepStatesOf (empty
  // parameters, infinite loss: none). Ceres' line searches accept the lowest point they
  // evaluated (of those with sufficient decrease), which may be older than the last
  // kRememberedEvaluations.
  mutable Remembered best_;
  mutable double best_loss_ = std::numeric_limits<double>::infinity();
  // Whether `evaluation` was at `parameters` (NumParameters() values), bit for bit.
  bool IsAt(const Remembered& evaluation, const double* parameters) const;
  // The index in remembered_ of the evaluation at `parameters` (the newest if several),
  // or -1.
  int RememberedIndex(const double* parameters) const;
  // Keeps remembered_[index] (kKeepBest: best_) as kept_ and forgets best_ (on every
  // rank; the index is rank 0's, and every rank remembers the same evaluations).
  static constexpr int kKeepBest = -1;
  void KeepRemembered(int index);
  mutable std::string last_failure_;
  WallTimer timer_;
  double deadline_ = 0.0;  // on timer_; 0: none
};

}  // namespace aqs

#endif  // AQS_TRAIN_END_TO_END_OBJECTIVE_H_
