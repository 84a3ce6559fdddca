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

#include <iostream>
#include <string>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/train_benchmark.h"

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

int Main() {
  TrainBenchmarkOptions options;
  options.model = FLAGS_model;
  options.iterations = FLAGS_iterations;
  options.modes = SplitList(FLAGS_modes);
  options.max_poses = FLAGS_max_poses;
  options.progress = FLAGS_progress;
  TrainOptions& train = options.train;
  train.num_threads = FLAGS_threads;
  train.solver.relative_force_tolerance = FLAGS_tolerance;
  train.energy_regularization = FLAGS_energy_regularization;
  train.line_search_starts = FLAGS_line_search_starts;
  train.adjoint_tolerance = FLAGS_adjoint_tolerance;
  train.max_step_expansion = FLAGS_max_step_expansion;
  train.lbfgs_scaling = FLAGS_lbfgs_scaling;
  std::string error;
  if (!SolverMethodFromFlag(&train.solver, &error)) {
    PrintError(error);
    return 1;
  }
  FlagNames flags = CommonFlagNames("train.");
  flags.insert(flags.end(), {{"model", "--model"},
                             {"iterations", "--iterations"},
                             {"modes", "--modes"},
                             {"max_poses", "--max_poses"},
                             {"train.energy_regularization", "--energy_regularization"},
                             {"train.solver.relative_force_tolerance", "--tolerance"},
                             {"train.adjoint_tolerance", "--adjoint_tolerance"},
                             {"train.max_step_expansion", "--max_step_expansion"}});
  return FinishJob(RunTrainBenchmark(options, std::cout, &error), error, flags);
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
