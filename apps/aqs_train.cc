// aqs_train: end-to-end training of a pre-trained model through the simulator, with
// progress lines, a CSV log (MODEL/train/log.csv) and checkpoints in the model
// directory: run it again after a kill (kill -9 included) to resume from the last
// checkpoint. It holds the model's writers' lock (docs/model_format.md, "Writing").
// Under mpirun (or with --mpi) the poses are shared among the ranks
// (docs/distributed.md); rank 0 logs and writes. Exit status: 0 done; 1 bad input (a
// file, a flag; --latent_dim, --hidden or --activation given and other than the
// model's), a model another process is writing, a model that cannot be simulated, or
// MPI wanted but not built.

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/learning_jobs.h"
#include "learning_flags.h"
#include "mpi_flags.h"

DECLARE_string(model);
DEFINE_bool(restart, false, "Ignore an earlier run's iteration count (start counting at 0, "
            "with a new log).");

int main(int argc, char** argv) {
  aqs::InitApp("Train a pre-trained model end to end.\n"
               "  aqs_train --model=MODEL [--train_iterations=200 --train_minutes=0 ...]\n"
               "  mpirun -np N aqs_train --model=MODEL ...   (poses shared among N ranks)",
               &argc, &argv);
  const std::unique_ptr<aqs::Communicator> ranks = aqs::StartRanks(&argc, &argv);
  aqs::TrainOptions options;
  aqs::ExpectedDecoder expected;
  std::string error;
  if (FLAGS_model.empty()) error = "--model is required";
  options.communicator = ranks.get();
  if (!error.empty() || !aqs::TrainOptionsFromFlags(&options, &error) ||
      !aqs::ExpectedDecoderFromFlags(&expected, &error)) {
    aqs::PrintRankError(ranks.get(), error);
    return 1;
  }
  const bool ok =
      aqs::RunTrainJob(FLAGS_model, options, FLAGS_restart, std::cout, &error, expected);
  if (!ok) aqs::PrintRankError(ranks.get(), aqs::FlagError(error, aqs::TrainFlagNames()));
  return aqs::ExitStatus(ok ? aqs::JobStatus::kOk : aqs::JobStatus::kBadInput);
}
