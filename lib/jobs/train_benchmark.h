#ifndef AQS_JOBS_TRAIN_BENCHMARK_H_
#define AQS_JOBS_TRAIN_BENCHMARK_H_

#include <ostream>
#include <string>
#include <vector>

#include "model/active_model.h"
#include "train/trainer.h"
#include "util/job_status.h"

namespace aqs {

// What aqs_bench_train does: the cost of end-to-end training iterations on a model, per
// pose and per iteration, as a ratio to one CHOLMOD factorization of the same stiffness
// measured in the same run (the unit). For each solver layout of `modes` it runs
// TrainEndToEnd (nothing saved) for `iterations` L-BFGS iterations on a copy of the
// model: per_pose, one solver and factor per pose (each pose's factor preconditions its
// next solves); stored, one solver per thread that keeps every pose's last factor in
// single precision between its evaluations; shared, one solver per thread and a fresh
// factorization per pose and evaluation.
struct TrainBenchmarkOptions {
  std::string model;  // a pre-trained model directory; required
  int iterations = 10;
  std::vector<std::string> modes = {"per_pose", "shared"};
  // Train on at most this many of the model's poses, i * P / N for i < N (0: all).
  int max_poses = 0;
  // Training's progress line of every iteration into the output.
  bool progress = false;
  // The training's options; per mode, max_iterations, max_factor_cache_gb,
  // max_restarts (0) and log_every are set by the benchmark.
  TrainOptions train;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// The unit and the sizes of one factor: the median of three numeric factorizations of
// the exact stiffness of pose 0 at its stored equilibrium (at rest without one; the
// projected stiffness, then growing diagonal shifts, where it is not positive definite).
struct FactorizationUnit {
  double seconds = 0.0;             // one numeric factorization, BLAS as configured
  double seconds_one_thread = 0.0;  // the same with one BLAS thread (as training's threads)
  double factor_nonzeros = 0.0;     // of L
  double factor_bytes = 0.0;        // the numeric factor's storage (supernodal blocks)
  double stored_bytes = 0.0;        // a single-precision copy of its values (StoredFactor)
  double store_seconds = 0.0;       // keeping such a copy, and restoring it
  double restore_seconds = 0.0;
  // CG iterations on the factorized stiffness itself with the restored copy as the
  // preconditioner, to a relative residual of 1e-10 (-1: not reached in 100): what single
  // precision costs.
  int restored_cg_iterations = -1;
  double stiffness_nonzeros = 0.0;
  int dofs = 0;
};
FactorizationUnit MeasureFactorizationUnit(const ActiveModel& model);

// Keeps n (< num_poses) of the model's poses, i * num_poses / n for i < n, with their
// latents, states and bone transforms.
void KeepSpreadPoses(int n, ActiveModel* model);

// Runs the benchmark and prints its figures to `out`: the model's unit and sizes, then a
// row per mode. Status kBadInput (with *error) for invalid options or an unreadable or
// untrained model, kNotConverged if a training run fails.
JobStatus RunTrainBenchmark(const TrainBenchmarkOptions& options, std::ostream& out,
                            std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_TRAIN_BENCHMARK_H_
