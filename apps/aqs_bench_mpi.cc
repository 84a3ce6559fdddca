// aqs_bench_mpi: strong scaling of end-to-end training over MPI ranks, and the cost of
// the reductions of the decoder's parameter vector (docs/distributed.md).
//
//   mpirun -np N aqs_bench_mpi --model=DIR [--iterations=5] [--repeats=1]
//
// Flags only; the benchmark is RunMpiBenchmark (lib/jobs/mpi_benchmark.h). Every rank has
// --threads threads (default 1 under mpirun) and one BLAS thread.

#include <iostream>
#include <string>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/mpi_benchmark.h"
#include "mpi_flags.h"

DEFINE_int32(iterations, 5, "L-BFGS iterations per run.");
DEFINE_int32(repeats, 1, "Runs on 1 rank and on all ranks, alternating.");
DEFINE_double(tolerance, 1e-6, "Relative force tolerance of the training equilibria.");
DECLARE_int32(threads);
DECLARE_string(model);

int main(int argc, char** argv) {
  aqs::InitApp("Strong scaling of training over MPI ranks, and the parameter reductions.\n"
               "  mpirun -np N aqs_bench_mpi --model=DIR [--iterations=5] [--repeats=1]",
               &argc, &argv);
  const std::unique_ptr<aqs::Communicator> ranks = aqs::StartRanks(&argc, &argv);
  aqs::MpiBenchmarkOptions options;
  options.model = FLAGS_model;
  options.iterations = FLAGS_iterations;
  options.repeats = FLAGS_repeats;
  options.train.num_threads = FLAGS_threads;
  options.train.solver.relative_force_tolerance = FLAGS_tolerance;
  std::string error;
  aqs::JobStatus status = aqs::JobStatus::kBadInput;
  if (aqs::SolverMethodFromFlag(&options.train.solver, &error)) {
    status = aqs::RunMpiBenchmark(options, ranks.get(), std::cout, &error);
  }
  if (status != aqs::JobStatus::kOk) {
    aqs::FlagNames flags = aqs::CommonFlagNames("train.");
    flags.insert(flags.end(), {{"model", "--model"},
                               {"iterations", "--iterations"},
                               {"repeats", "--repeats"},
                               {"train.solver.relative_force_tolerance", "--tolerance"}});
    aqs::PrintRankError(ranks.get(), aqs::FlagError(error, flags));
  }
  return aqs::ExitStatus(status);
}
