// aqs_bench_train: the cost of end-to-end training iterations on a model, per pose and
// per iteration, as a ratio to one CHOLMOD factorization of the same stiffness measured
// in the same run.
//
// Runs TrainEndToEnd (the training aqs_train does, nothing saved) for --iterations
// L-BFGS iterations on a copy of the model, in each solver layout of --modes: per_pose,
// one solver and factor per pose (each pose's factor preconditions its next solves:
// TrainOptions::max_factor_cache_gb); stored, one solver per thread that keeps every
// pose's last factor in single precision between its evaluations, to the same use;
// shared, one solver per thread and a fresh factorization per pose and evaluation.
// Printed per mode:
//   seconds per iteration (wall), and per pose per iteration over the unit;
//   evaluations per iteration (1 + the line search's extra trials);
//   factorizations per pose per iteration (solves and adjoints), and how many Newton
//   steps and adjoints were solved by CG on an earlier factor instead;
//   the parts, per pose per iteration over the unit: equilibrium solves, adjoints
//   (thread time), the decoder (wall time over poses).
// The unit: the median of three numeric factorizations of the exact stiffness of pose 0
// at its stored equilibrium. Also printed: the size of one factor (CHOLMOD's symbolic
// analysis: non-zeros of L, in GB of doubles, the figure TrainOptions::max_factor_cache_gb
// is compared with), the stiffness' non-zeros, the resident memory with the model loaded,
// and per mode the peak resident memory of the process so far (run one mode per process,
// --modes=shared then --modes=per_pose, for each mode's own peak).

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <gflags/gflags.h>

#include "app_common.h"
#include "learn/decoder.h"
#include "model/model_io.h"
#include "train/trainer.h"
#include "util/blas.h"
#include "util/process_memory.h"
#include "util/wall_timer.h"

DEFINE_int32(iterations, 10, "L-BFGS iterations per mode.");
DEFINE_bool(progress, false, "Print training's progress line of every iteration (with its "
            "factorizations per pose), to tell the first iterations' cost from the later ones'.");
DEFINE_string(modes, "per_pose,shared", "Solver layouts to measure: per_pose (one solver and "
              "factor per pose), stored (one solver per thread, each pose's factor kept in single "
              "precision) and/or shared (one solver per thread, nothing kept).");
DEFINE_double(tolerance, 1e-6, "Relative force tolerance of the training equilibria.");
DEFINE_double(energy_regularization, 0.0, "Weight of the equilibrium-energy regularizer, as "
              "aqs_train's (the demo trains with 0.1).");
DEFINE_int32(max_poses, 0, "Train on at most this many of the model's poses, spread evenly "
             "over its pose list (poses i * P / N for i < N); 0: all. The figures are per pose.");
DEFINE_bool(line_search_starts, true, "Start a line-search trial's solves from the equilibria of "
            "two earlier evaluations on its line, interpolated (TrainOptions::line_search_starts).");
DEFINE_double(adjoint_tolerance, 1e-10, "Relative residual of the adjoint solves done by CG on an "
              "earlier factor (TrainOptions::adjoint_tolerance).");
DEFINE_bool(lbfgs_scaling, true, "Scale L-BFGS' initial inverse Hessian by s'y / y'y of the "
            "last step (TrainOptions::lbfgs_scaling, Ceres' "
            "use_approximate_eigenvalue_bfgs_scaling).");
DEFINE_double(max_step_expansion, 10.0, "How far the line search may expand a step that is too "
              "short (TrainOptions::max_step_expansion, Ceres' max_line_search_step_expansion).");
DECLARE_int32(threads);
DECLARE_string(model);

namespace aqs {
namespace {

struct Unit {
  double seconds = 0.0;          // one numeric factorization (median), BLAS as configured
  double seconds_one_thread = 0.0;  // the same with one BLAS thread
  double factor_nonzeros = 0.0;  // of L
  double factor_bytes = 0.0;     // the numeric factor's storage (supernodal blocks)
  double stored_bytes = 0.0;     // a single-precision copy of its values (StoredFactor)
  double store_seconds = 0.0;    // keeping such a copy, and restoring it
  double restore_seconds = 0.0;
  // CG iterations on the factorized stiffness itself with the restored copy as the
  // preconditioner, to a relative residual of 1e-10 (-1: not reached in 100): what single
  // precision costs.
  int restored_cg_iterations = -1;
  double stiffness_nonzeros = 0.0;
  int dofs = 0;
};

Unit MeasureUnit(const ActiveModel& model) {
  const ShapeTargetModel physics(model.mesh, model.mu);
  const BoundaryConditions bc = PoseBoundaryConditions(model, 0);
  StiffnessFactorization factorization(physics, FixedVertexMask(bc, model.mesh.num_vertices()), 1);
  ActuationMatrix a;
  DecoderWorkspace workspace;
  model.decoder->Decode(model.decoder_params.data(), model.latents.col(0), &a, &workspace);
  const Eigen::Matrix3Xd x =
      model.states.size() > 0 && model.states[0].cols() == model.mesh.num_vertices()
          ? model.states[0]
          : model.mesh.vertices;
  factorization.Assemble(x, a, StiffnessKind::kExact);
  Unit unit;
  factorization.Analyze();
  unit.factor_nonzeros = factorization.cholesky().factor_nonzeros();
  unit.factor_bytes = factorization.cholesky().factor_bytes();
  unit.stored_bytes = factorization.cholesky().stored_factor_bytes();
  unit.stiffness_nonzeros = static_cast<double>(factorization.pattern().num_nonzeros());
  unit.dofs = factorization.cholesky().size();
  std::vector<double> seconds;
  std::string error;
  // Not positive definite at the stored state (or at rest, for a model without states):
  // the projected stiffness instead, then with growing diagonal shifts (the same
  // pattern and the same work per factorization).
  bool projected = false;
  double shift = 0.0;
  for (int i = 0, timed = 0; timed < 3 && i < 12; ++i) {
    WallTimer timer;
    if (!factorization.FactorizeAssembled(shift, &error)) {
      if (!projected) {
        factorization.Assemble(x, a, StiffnessKind::kProjected);
        projected = true;
      } else {
        shift = shift == 0.0 ? 1e-8 : 100.0 * shift;
      }
      continue;
    }
    if (i > 0) {  // the first includes the analysis
      seconds.push_back(timer.Seconds());
      ++timed;
    }
  }
  if (seconds.empty()) return unit;
  std::sort(seconds.begin(), seconds.end());
  unit.seconds = seconds[seconds.size() / 2];
  // Training runs one pose per thread with one BLAS thread each (TrainEndToEnd).
  const int blas_threads = BlasThreads();
  SetBlasThreads(1);
  seconds.clear();
  for (int i = 0; i < 3; ++i) {
    WallTimer timer;
    if (factorization.FactorizeAssembled(shift, &error)) seconds.push_back(timer.Seconds());
  }
  SetBlasThreads(blas_threads);
  StoredStiffnessFactor stored;
  WallTimer store_timer;
  if (factorization.StoreFactor(&stored)) {
    unit.store_seconds = store_timer.Seconds();
    WallTimer restore_timer;
    if (factorization.RestoreFactor(stored)) {
      unit.restore_seconds = restore_timer.Seconds();
      FactorReuseOptions reuse;
      reuse.max_iterations = 100;
      reuse.probe_iterations = 0;
      reuse.refresh_iterations = 0;
      const Eigen::MatrixXd b = Eigen::MatrixXd::Ones(factorization.cholesky().size(), 1);
      Eigen::MatrixXd solution;
      factorization.ResetCounters();
      if (factorization.SolveReusingFactor(b, reuse, &solution)) {
        unit.restored_cg_iterations = factorization.counters().cg_iterations;
      }
    }
  }
  if (!seconds.empty()) {
    std::sort(seconds.begin(), seconds.end());
    unit.seconds_one_thread = seconds[seconds.size() / 2];
  }
  return unit;
}

// Keeps n of the model's poses, i * num_poses / n for i < n (with their latents, states
// and bone transforms).
void KeepSpreadPoses(int n, ActiveModel* model) {
  const int total = model->num_poses();
  std::vector<int> kept;
  for (int i = 0; i < n; ++i) kept.push_back(static_cast<int>(static_cast<long>(i) * total / n));
  std::vector<TrainingPose> poses;
  Eigen::MatrixXd latents(model->latents.rows(), n);
  std::vector<Eigen::Matrix3Xd> states;
  for (int i = 0; i < n; ++i) {
    poses.push_back(model->poses[kept[i]]);
    latents.col(i) = model->latents.col(kept[i]);
    if (static_cast<int>(model->states.size()) == total) states.push_back(model->states[kept[i]]);
  }
  for (Bone& bone : model->bones) {
    std::vector<RigidTransform> transforms;
    for (int p : kept) transforms.push_back(bone.pose_transforms[p]);
    bone.pose_transforms = transforms;
  }
  model->poses = poses;
  model->latents = latents;
  model->states = states;
  std::printf("poses kept (%d of %d):", n, total);
  for (const TrainingPose& pose : model->poses) std::printf(" %s", pose.name.c_str());
  std::printf("\n");
}

int Main() {
  if (FLAGS_model.empty() || FLAGS_iterations < 1 || FLAGS_threads < 1 || !(FLAGS_tolerance > 0)) {
    PrintError("--model is required; --iterations and --threads must be >= 1, --tolerance > 0");
    return 1;
  }
  ActiveModel model;
  std::string error;
  if (!LoadModel(FLAGS_model, &model, &error)) {
    PrintError(error);
    return 1;
  }
  if (!model.decoder) {
    PrintError(FLAGS_model + ": the model is not pre-trained (no decoder)");
    return 1;
  }
  if (FLAGS_max_poses < 0) {
    PrintError("--max_poses must be >= 0 (0: all poses)");
    return 1;
  }
  if (FLAGS_max_poses > 0 && FLAGS_max_poses < model.num_poses()) KeepSpreadPoses(FLAGS_max_poses, &model);
  const Unit measured = MeasureUnit(model);
  const double unit = measured.seconds;
  std::printf("model %s: %d elements, %d poses, %d decoder parameters; unit (one factorization) "
              "%.4f s; %d threads\n",
              FLAGS_model.c_str(), model.mesh.num_tets(), model.num_poses(),
              model.decoder->num_parameters(), unit, FLAGS_threads);
  std::printf("unit with one BLAS thread (as each training thread factorizes): %.4f s\n",
              measured.seconds_one_thread);
  std::printf("stiffness: %d free DOFs, %.4g non-zeros (upper triangle); factor: %.4g non-zeros, "
              "stored in %.3f GB (x %d poses = %.2f GB); resident with the model loaded %.2f GB\n",
              measured.dofs, measured.stiffness_nonzeros, measured.factor_nonzeros,
              measured.factor_bytes / 1e9, model.num_poses(),
              measured.factor_bytes * model.num_poses() / 1e9, CurrentResidentBytes() / 1e9);
  std::printf("single-precision copy of a factor (mode stored): %.3f GB (x %d poses = %.2f GB); "
              "keeping one %.4f s, restoring it %.4f s (%.3f units together); CG iterations "
              "on the same stiffness with it as the preconditioner, to 1e-10: %d\n",
              measured.stored_bytes / 1e9, model.num_poses(),
              measured.stored_bytes * model.num_poses() / 1e9, measured.store_seconds,
              measured.restore_seconds,
              unit > 0 ? (measured.store_seconds + measured.restore_seconds) / unit : 0.0,
              measured.restored_cg_iterations);
  std::fflush(stdout);  // the model's figures before the (long) training runs
  std::printf("%-9s %6s %8s %9s %7s %9s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s\n", "mode",
              "iters", "s/iter", "pose/unit", "evals", "fact/pose", "adj_fact", "reused", "cg/pose",
              "newton", "lbfgs", "line", "solve", "adjoint", "decoder", "loss", "peak_GB");
  for (const std::string& mode : SplitList(FLAGS_modes)) {
    if (mode != "per_pose" && mode != "shared" && mode != "stored") {
      PrintError("--modes: '" + mode + "' is not per_pose, stored or shared");
      return 1;
    }
    ActiveModel copy = model;
    TrainOptions options;
    options.max_iterations = FLAGS_iterations;
    options.num_threads = FLAGS_threads;
    options.solver.relative_force_tolerance = FLAGS_tolerance;
    options.energy_regularization = FLAGS_energy_regularization;
    if (!SolverMethodFromFlag(&options.solver, &error)) {
      PrintError(error);
      return 1;
    }
    // stored: a budget that holds every pose's single-precision copy but not a solver
    // per pose (whose factors are in double precision, with their SVD caches).
    options.max_factor_cache_gb = mode == "per_pose" ? 1e9
                                  : mode == "stored" ? 1.0001 * measured.stored_bytes * model.num_poses() / 1e9
                                                     : 0.0;
    options.max_restarts = 0;
    options.line_search_starts = FLAGS_line_search_starts;
    options.adjoint_tolerance = FLAGS_adjoint_tolerance;
    options.max_step_expansion = FLAGS_max_step_expansion;
    options.lbfgs_scaling = FLAGS_lbfgs_scaling;
    options.log_every = FLAGS_progress ? 1 : 0;
    if (!options.Validate(&error)) {
      FlagNames flags = CommonFlagNames();
      flags.insert(flags.end(), {{"energy_regularization", "--energy_regularization"},
                                 {"solver.relative_force_tolerance", "--tolerance"},
                                 {"adjoint_tolerance", "--adjoint_tolerance"},
                                 {"max_step_expansion", "--max_step_expansion"},
                                 {"max_iterations", "--iterations"}});
      PrintError(FlagError(error, flags));
      return 1;
    }
    TrainReport report;
    std::ostringstream quiet;
    std::ostream& log = FLAGS_progress ? std::cout : static_cast<std::ostream&>(quiet);
    if (!TrainEndToEnd(options, &copy, &report, log, &error)) {
      PrintError(error);
      return 2;
    }
    const EvaluationCounters& c = report.iteration_cost;
    const int iterations = std::max(1, report.iterations - report.iterations_before);
    const double per_pose_iteration = 1.0 / (static_cast<double>(iterations) * model.num_poses());
    const double u = unit > 0 ? unit : 1.0;
    std::printf("%-9s %6d %8.3f %9.2f %7.2f %9.2f %8.2f %8.2f %8.1f %8.2f %8.2f %8.2f %8.2f %8.2f "
                "%8.2f %8.3e %8.2f\n",
                mode.c_str(), iterations, c.seconds / iterations,
                c.seconds * per_pose_iteration / u, c.evaluations / static_cast<double>(iterations),
                c.factorizations * per_pose_iteration,
                c.adjoint_factorizations * per_pose_iteration, c.reused_solves * per_pose_iteration,
                c.cg_iterations * per_pose_iteration, c.newton_steps * per_pose_iteration,
                c.lbfgs_iterations * per_pose_iteration, c.line_starts * per_pose_iteration,
                c.solve_seconds * per_pose_iteration / u,
                c.adjoint_seconds * per_pose_iteration / u,
                c.decoder_seconds * per_pose_iteration / u, report.final_loss,
                PeakResidentBytes() / 1e9);
    std::fflush(stdout);
  }
  std::printf(
      "pose/unit: wall seconds per pose per iteration over the unit; evals: evaluations per "
      "iteration (1 + line-search trials);\nfact/pose, adj_fact, reused, cg/pose: factorizations "
      "(all; of them for adjoints), CG solves on an earlier factor, and CG iterations per pose "
      "per iteration;\nnewton, lbfgs: "
      "Newton steps and L-BFGS iterations per pose per iteration; line: solves started on a "
      "line-search line per pose per iteration (--line_search_starts); solve, "
      "adjoint: thread seconds per pose per iteration over the unit; decoder: wall seconds "
      "per pose per iteration over the unit;\npeak_GB: the process's peak resident memory so far "
      "(one mode per process for each mode's own peak).\n");
  return 0;
}

}  // namespace
}  // namespace aqs

int main(int argc, char** argv) {
  aqs::InitApp(
      "Cost of end-to-end training iterations, per pose, in factorizations.\n"
      "  aqs_bench_train --model=DIR [--iterations=10] [--modes=per_pose,shared]",
      &argc, &argv);
  return aqs::Main();
}
