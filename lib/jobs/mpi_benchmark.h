#ifndef AQS_JOBS_MPI_BENCHMARK_H_
#define AQS_JOBS_MPI_BENCHMARK_H_

#include <ostream>
#include <string>

#include "dist/communicator.h"
#include "train/trainer.h"
#include "util/job_status.h"

namespace aqs {

// What aqs_bench_mpi does (docs/distributed.md): strong scaling of end-to-end training
// over the ranks of a communicator, and the cost of the reductions an evaluation makes.
struct MpiBenchmarkOptions {
  std::string model;  // a pre-trained model directory, read on every rank; required
  int iterations = 5;  // L-BFGS iterations per run
  int repeats = 1;     // runs on rank 0 alone and on all ranks, alternating
  // Timed calls of each reduction (after 2 untimed ones); their median and best are
  // printed.
  int reduction_calls = 20;
  // The training's options; per run, max_iterations (= iterations), max_restarts (0),
  // log_every (0) and communicator are set by the benchmark.
  TrainOptions train;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// One training run's figures.
struct MpiTrainingRun {
  int ranks = 1;
  int iterations = 0;
  int evaluations = 0;
  double evaluation_seconds = 0.0;  // wall time of the evaluations (line-search trials too)
  double wall_seconds = 0.0;        // the whole TrainEndToEnd call
  double cpu_seconds = 0.0;         // the busiest rank's processor seconds for the run
  double SecondsPerIteration() const;
  double SecondsPerEvaluation() const;
};

// Runs TrainEndToEnd on a copy of the model (nothing saved), first on rank 0 alone (the
// other ranks wait) and then on all ranks of `ranks` (null: this process alone, which
// runs only the first), `repeats` times each. Then, with all ranks starting together,
// times SumToRoot (what an evaluation does with the gradient), SumToAll and Broadcast
// (what it does with the parameters) of vectors of the decoder's parameter count and of
// the whole training vector (parameters and latents). Collective: every rank calls it
// with the same options. Rank 0 prints to `out`: the machine and its load average
// before and after, the model, a row per run, the speed-up and parallel efficiency
// t1 / (N tN) of the best runs per evaluation, per iteration and from processor time,
// and a row per reduction (median and best milliseconds, GB/s of the median). Status
// kBadInput (with *error on every rank) for invalid options or a model that is
// unreadable, differs between ranks or is not pre-trained; kNotConverged if a training
// run fails.
JobStatus RunMpiBenchmark(const MpiBenchmarkOptions& options, const Communicator* ranks,
                          std::ostream& out, std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_MPI_BENCHMARK_H_
