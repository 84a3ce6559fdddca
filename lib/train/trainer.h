#ifndef AQS_TRAIN_TRAINER_H_
#define AQS_TRAIN_TRAINER_H_

#include <ostream>
#include <string>

#include "equilibrium/quasistatic_solver.h"
#include "model/active_model.h"
#include "train/evaluation_counters.h"

namespace aqs {

class Communicator;

struct TrainOptions {
  // Weight of the latent regularizer (1/P) sum_p |z_p|^2.
  double latent_regularization = 1e-3;
  // Weight of the decoder regularizer |params|^2 (weight decay on every weight and bias
  // of the decoder's network). With the latent regularizer alone, the network's first
  // layer can grow as the latents shrink; this term fixes that scale. 0: none.
  double decoder_regularization = 0.0;
  // Weight of the equilibrium-energy regularizer
  //   (1/P) sum_p E(x*_p, a_p) / (sum_e mu_e V_e),
  // each pose's elastic energy at its equilibrium relative to the body's stiffness times
  // volume (a mean squared mismatch between F and the shape targets' R S). It penalizes
  // actuations that fight each other: pre-stressed equilibria near buckling, where
  // Newton crawls and contact paths halve. Its gradient needs no adjoint: at an
  // equilibrium dE/dx = 0, so dE(x*(a), a)/da = dE/da at fixed x. 0: none.
  double energy_regularization = 0.0;
  // L-BFGS iterations in all (counting those of earlier runs when resuming).
  int max_iterations = 200;
  // Stop (successfully, after saving) once this much wall time was spent in this run
  // (0: no limit).
  double max_seconds = 0.0;
  // The per-pose equilibria (tolerance etc.; num_threads is set to 1: poses run in
  // parallel instead).
  QuasistaticSolverOptions solver;
  int num_threads = 2;  // poses solved in parallel
  // Keep one solver, with its stiffness factor, per pose while all the factors together
  // take at most this many GB (estimated from CHOLMOD's symbolic analysis, with each
  // solver's element SVD cache, physics/polar_cache.h): each pose's
  // factor then preconditions its next evaluation's Newton steps and adjoint by CG,
  // which mostly needs no factorization. Above it, one solver per thread, which keeps
  // each pose's last factor in single precision between the pose's evaluations (half
  // a factor's values, StiffnessFactorization::StoreFactor) for as many poses as fit this
  // budget, to the same use; the other poses factorize at every evaluation (their
  // adjoint still reuses the solve's last factor).
  double max_factor_cache_gb = 4.0;
  // A line-search trial on the line through two earlier evaluations (a backtrack, a zoom
  // or an expansion of the step; train/line_search_start.h) starts each pose from its
  // equilibria there, interpolated linearly along the line, where that start's largest
  // force is below the usual warm start's (the last evaluation's equilibrium, predicted
  // to first order with the pose's factor).
  bool line_search_starts = true;
  // The adjoint solve's relative residual when it reuses a factor by CG (a fresh
  // factorization solves it exactly): |K lambda - dL/dx| <= adjoint_tolerance |dL/dx|,
  // in [1e-14, 0.01]. The gradient is then off by about that fraction.
  double adjoint_tolerance = 1e-10;
  // How far the line search may expand a step that is too short (Ceres'
  // max_line_search_step_expansion, > 1): a longer trial starts its solves farther
  // from the warm starts.
  double max_step_expansion = 10.0;
  // L-BFGS' initial inverse Hessian: gamma I with gamma = s^T y / y^T y of the last
  // accepted step (Ceres' use_approximate_eigenvalue_bfgs_scaling), instead of I. Then
  // the search direction has the scale of the loss' curvature along the last step.
  bool lbfgs_scaling = true;
  // Checkpoints and logs: the model directory the learned state is saved into every
  // checkpoint_every iterations, as one unit (SaveLearnedState: decoder, latents,
  // states and the checkpoint, model/model_io.h), and train/log.csv. The caller should
  // hold the model's lock (model/model_directory.h). Empty: no saving.
  std::string model_directory;
  int checkpoint_every = 1;
  // L-BFGS restarts (empty memory) allowed after the line search stalls; see
  // TrainEndToEnd.
  int max_restarts = 50;
  int log_every = 1;  // progress lines
  // Gauss-Newton latent steps (train/latent_refit.h): with latent_refit_iterations > 0,
  // before the first L-BFGS iteration of a run that starts at iteration 0 (not a
  // resumed one), each pose's latent is refitted alone, decoder fixed, by that many
  // Levenberg-Marquardt iterations on its share of L; with latent_refit_every > 0 again
  // after every that many iterations (then L-BFGS continues with an empty memory, which
  // costs more than the refit gains: on the demo face, 5-minute budget, a refit at the
  // start only ends at loss 2.04e-3, every 20 iterations at 2.42e-3, none at 2.24e-3).
  // 0: no refits; latent_refit_every > 0 needs latent_refit_iterations > 0 (Validate).
  // Distributed runs refit too (docs/distributed.md).
  int latent_refit_iterations = 0;
  int latent_refit_every = 0;
  // Distributed training (docs/distributed.md): every rank of the communicator calls
  // TrainEndToEnd with the same options and the same model (dist/model_sharing.h); rank
  // r owns the poses p with p % size == r (their equilibria, warm starts and decoder
  // back-propagation), rank 0 runs L-BFGS, logs, and alone writes checkpoints and the
  // log. num_threads and max_factor_cache_gb are per rank. Null (or one rank): one
  // process.
  const Communicator* communicator = nullptr;

  // Checks every field (train/train_options.cc); false with *error naming the first
  // bad one.
  bool Validate(std::string* error) const;
};

struct TrainReport {
  int iterations_before = 0;  // done by earlier runs (from the checkpoint)
  int iterations = 0;         // in all, after this run
  double initial_loss = 0.0;
  double final_loss = 0.0;
  double initial_mean_surface_error = 0.0;  // before this run's iterations
  // Mean and largest distance between the simulated embedded surface and the pose
  // surface over all training poses and surface vertices, at the end (model units).
  double mean_surface_error = 0.0;
  double max_surface_error = 0.0;
  double seconds = 0.0;
  int restarts = 0;  // L-BFGS restarts after a stalled line search
  int latent_refits = 0;  // rounds of latent refits (TrainOptions::latent_refit_iterations)
  std::string termination;
  // What this run's L-BFGS iterations cost (their evaluations, line-search trials
  // included; not the start and final evaluations).
  EvaluationCounters iteration_cost;
};

// End-to-end training through the simulator: decoder parameters and per-pose latents
// minimize
//
//   L = (1/(P N)) sum_p sum_i |p_i(x*(a(z_p))) - y_pi|^2 + latent_regularization (1/P) sum_p |z_p|^2
//       + decoder_regularization |params|^2
//       + energy_regularization (1/P) sum_p E(x*_p, a_p) / (sum_e mu_e V_e)
//
// (p_i: embedded surface vertex i, y_pi its position in pose p, N surface vertices,
// x* the equilibrium under pose p's boundary conditions), by Ceres' L-BFGS
// (GradientProblemSolver). The gradient comes from implicit differentiation (one
// adjoint solve per pose) back-propagated through the decoder. Equilibria are
// warm-started from each pose's last state and computed in parallel. The model must be
// pre-trained (decoder and latents set); its states are used as warm starts and updated.
//
// Progress lines (iteration, loss, mean surface error, gradient norm, time, ETA) go to
// `log`; with model_directory set, every checkpoint saves the learned state with
// model->checkpoint (iterations done, loss), so that a killed run resumes by loading
// the model and calling this again: it continues after model->checkpoint.iterations
// (the L-BFGS memory restarts empty), and its start loss is the logged loss of that
// iteration (the saved equilibria are those of the logged point). train/log.csv gets
// one row per iteration; a resumed run first cuts it to the rows up to its checkpoint,
// a run without a checkpoint starts it anew. When the line search stalls (the loss is only as smooth as the
// equilibria are converged) before the iteration or time budget is used, L-BFGS
// restarts from the current point, up to max_restarts times while restarts progress. Returns false with *error if the poses' equilibria cannot be solved
// at the starting point.
//
// With options.communicator spanning several ranks, every rank calls it: rank 0 as
// above (its report and log), the others serve rank 0's evaluations on their poses and
// return what rank 0 returned, with an empty *error (rank 0 reports) and no report.
// Checkpoints hold every pose's equilibrium (gathered to rank 0), so a run resumes
// with any number of ranks.
bool TrainEndToEnd(const TrainOptions& options, ActiveModel* model, TrainReport* report,
                   std::ostream& log, std::string* error);

// Whether training saves a checkpoint after `iteration` (counted over every run of the
// model, as the log's rows are), `run_iteration` of them this run's: at the multiples of
// `every` (> 0; 0: never), as the periodic latent refits are, so that a run resumed from
// another iteration (one that ended on its budget) keeps the same schedule; never at a
// run's start point (run_iteration 0, the last run's checkpoint). Each run also saves
// where it ends.
bool CheckpointDue(int iteration, int run_iteration, int every);

}  // namespace aqs

#endif  // AQS_TRAIN_TRAINER_H_
