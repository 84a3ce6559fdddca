#include "jobs/train_benchmark.h"

#include <algorithm>
#include <sstream>

#include "learn/decoder.h"
#include "model/model_io.h"
#include "util/blas.h"
#include "util/option_checks.h"
#include "util/process_memory.h"
#include "util/machine_info.h"
#include "util/string_format.h"
#include "util/wall_timer.h"

namespace aqs {
bool TrainBenchmarkOptions::Validate(std::string* error) const {
  bool modes_ok = !modes.empty();
  std::string bad_mode;
  for (const std::string& mode : modes) {
    if (mode != "per_pose" && mode != "shared" && mode != "stored") {
      modes_ok = false;
      bad_mode = mode;
    }
  }
  std::string train_error;
  const bool train_ok = train.Validate(&train_error);
  return OptionChecks()
      .Require(!model.empty(), "model is required")
      .IntAtLeast("iterations", iterations, 1)
      .Require(modes_ok, bad_mode.empty()
                             ? std::string("modes must list per_pose, stored and/or shared")
                             : "modes: '" + bad_mode + "' is not per_pose, stored or shared")
      .IntAtLeast("max_poses", max_poses, 0)
      .Nested("train", train_ok, train_error)
      .Done(error);
}

FactorizationUnit MeasureFactorizationUnit(const ActiveModel& model) {
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
  FactorizationUnit unit;
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
}

JobStatus RunTrainBenchmark(const TrainBenchmarkOptions& options, std::ostream& out,
                            std::string* error) {
  if (!options.Validate(error)) return JobStatus::kBadInput;
  ActiveModel model;
  if (!LoadModel(options.model, &model, error)) return JobStatus::kBadInput;
  if (!model.decoder) {
    *error = options.model + ": the model is not pre-trained (no decoder)";
    return JobStatus::kBadInput;
  }
  out << BenchmarkMachineLine() << "\n";
  if (options.max_poses > 0 && options.max_poses < model.num_poses()) {
    const int total = model.num_poses();
    KeepSpreadPoses(options.max_poses, &model);
    out << StringPrintf("poses kept (%d of %d):", options.max_poses, total);
    for (const TrainingPose& pose : model.poses) out << StringPrintf(" %s", pose.name.c_str());
    out << "\n";
  }
  const FactorizationUnit measured = MeasureFactorizationUnit(model);
  const double unit = measured.seconds;
  const int threads = options.train.num_threads;
  out << StringPrintf(
      "model %s: %d elements, %d poses, %d decoder parameters; unit (one factorization) "
      "%.4f s; %d threads\n",
      options.model.c_str(), model.mesh.num_tets(), model.num_poses(),
      model.decoder->num_parameters(), unit, threads);
  out << StringPrintf("unit with one BLAS thread (as each training thread factorizes): %.4f s\n",
                      measured.seconds_one_thread);
  out << StringPrintf(
      "stiffness: %d free DOFs, %.4g non-zeros (upper triangle); factor: %.4g non-zeros, "
      "stored in %.3f GB (x %d poses = %.2f GB); resident with the model loaded %.2f GB\n",
      measured.dofs, measured.stiffness_nonzeros, measured.factor_nonzeros,
      measured.factor_bytes / 1e9, model.num_poses(),
      measured.factor_bytes * model.num_poses() / 1e9, CurrentResidentBytes() / 1e9);
  out << StringPrintf(
      "single-precision copy of a factor (mode stored): %.3f GB (x %d poses = %.2f GB); "
      "keeping one %.4f s, restoring it %.4f s (%.3f units together); CG iterations "
      "on the same stiffness with it as the preconditioner, to 1e-10: %d\n",
      measured.stored_bytes / 1e9, model.num_poses(),
      measured.stored_bytes * model.num_poses() / 1e9, measured.store_seconds,
      measured.restore_seconds,
      unit > 0 ? (measured.store_seconds + measured.restore_seconds) / unit : 0.0,
      measured.restored_cg_iterations);
  out << std::flush;  // the model's figures before the (long) training runs
  out << StringPrintf("%-9s %6s %8s %9s %7s %9s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s %8s\n",
                      "mode", "iters", "s/iter", "pose/unit", "evals", "fact/pose", "adj_fact",
                      "reused", "cg/pose", "newton", "lbfgs", "line", "solve", "adjoint", "decoder",
                      "loss", "peak_GB");
  for (const std::string& mode : options.modes) {
    ActiveModel copy = model;
    TrainOptions train = options.train;
    train.max_iterations = options.iterations;
    // stored: a budget that holds every pose's single-precision copy but not a solver
    // per pose (whose factors are in double precision, with their SVD caches).
    train.max_factor_cache_gb = mode == "per_pose" ? 1e9
                                : mode == "stored"
                                    ? 1.0001 * measured.stored_bytes * model.num_poses() / 1e9
                                    : 0.0;
    train.max_restarts = 0;
    train.log_every = options.progress ? 1 : 0;
    TrainReport report;
    std::ostringstream quiet;
    std::ostream& log = options.progress ? out : static_cast<std::ostream&>(quiet);
    if (!TrainEndToEnd(train, &copy, &report, log, error)) return JobStatus::kNotConverged;
    const EvaluationCounters& c = report.iteration_cost;
    const int iterations = std::max(1, report.iterations - report.iterations_before);
    const double per_pose_iteration = 1.0 / (static_cast<double>(iterations) * model.num_poses());
    const double u = unit > 0 ? unit : 1.0;
    out << StringPrintf(
        "%-9s %6d %8.3f %9.2f %7.2f %9.2f %8.2f %8.2f %8.1f %8.2f %8.2f %8.2f %8.2f %8.2f "
        "%8.2f %8.3e %8.2f\n",
        mode.c_str(), iterations, c.seconds / iterations, c.seconds * per_pose_iteration / u,
        c.evaluations / static_cast<double>(iterations), c.factorizations * per_pose_iteration,
        c.adjoint_factorizations * per_pose_iteration, c.reused_solves * per_pose_iteration,
        c.cg_iterations * per_pose_iteration, c.newton_steps * per_pose_iteration,
        c.lbfgs_iterations * per_pose_iteration, c.line_starts * per_pose_iteration,
        c.solve_seconds * per_pose_iteration / u, c.adjoint_seconds * per_pose_iteration / u,
        c.decoder_seconds * per_pose_iteration / u, report.final_loss, PeakResidentBytes() / 1e9);
    out << std::flush;
  }
  out << "pose/unit: wall seconds per pose per iteration over the unit; evals: evaluations per "
         "iteration (1 + line-search trials);\nfact/pose, adj_fact, reused, cg/pose: "
         "factorizations (all; of them for adjoints), CG solves on an earlier factor, and CG "
         "iterations per pose per iteration;\nnewton, lbfgs: Newton steps and L-BFGS iterations "
         "per pose per iteration; line: solves started on a line-search line per pose per "
         "iteration (--line_search_starts); solve, adjoint: thread seconds per pose per "
         "iteration over the unit; decoder: wall seconds per pose per iteration over the "
         "unit;\npeak_GB: the process's peak resident memory so far (one mode per process for "
         "each mode's own peak).\n";
  return JobStatus::kOk;
}

}  // namespace aqs
