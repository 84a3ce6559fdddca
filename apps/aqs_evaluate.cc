// aqs_evaluate: per-pose errors of the physics model and of three surface-only baselines
// of the same latent size (an auto-encoder, PCA, PCA about the neutral) on training and
// held-out poses, as
// Markdown and CSV tables and per-vertex error fields (PLY). Under mpirun (or with
// --mpi) the held-out poses' fits are shared among the ranks (docs/distributed.md);
// rank 0 writes everything.
// Exit status: 0 done; 1 bad input, or MPI wanted but not built.

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "evaluate_flags.h"
#include "mpi_flags.h"

int main(int argc, char** argv) {
  aqs::InitApp("Evaluate a trained model against surface-only baselines.\n"
               "  aqs_evaluate --model=MODEL --test_poses=SPEC --output_dir=DIR\n"
               "  mpirun -np N aqs_evaluate ...   (held-out fits shared among N ranks)",
               &argc, &argv);
  const std::unique_ptr<aqs::Communicator> ranks = aqs::StartRanks(&argc, &argv);
  aqs::EvaluateJobOptions options;
  std::vector<aqs::EvaluationRow> rows;
  std::string error;
  bool ok = aqs::EvaluateOptionsFromFlags(&options, &error);
  options.communicator = ranks.get();
  // The flags read files (--test_poses: a list, a folder, a glob) that another machine
  // may see otherwise: the ranks agree before the job's collectives.
  if (ranks) ok = ranks->Agree(ok, &error);
  if (!ok) {
    aqs::PrintRankError(ranks.get(), error);
    return 1;
  }
  ok = aqs::RunEvaluateJob(options, std::cout, &rows, &error);
  if (!ok) aqs::PrintRankError(ranks.get(), aqs::FlagError(error, aqs::EvaluateFlagNames()));
  return aqs::ExitStatus(ok ? aqs::JobStatus::kOk : aqs::JobStatus::kBadInput);
}
