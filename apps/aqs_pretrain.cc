// aqs_pretrain: a decoder and one latent per pose fitted to a prepared model's
// volumetric targets (supervised), to start end-to-end training from.
// It holds the model's writers' lock and replaces the model as a whole
// (docs/model_format.md, "Writing"). It writes checkpoints into the model's pretrain/
// folder every minute (--pretrain_checkpoint_seconds); run again after a kill, it
// resumes from the last (--restart: not).
// Exit status: 0 done; 1 bad input (a file, a flag, a decoder whose memory estimate is
// above --max_memory_gb) or a model another process is writing. Under mpirun (or with
// --mpi; docs/distributed.md) rank 0 pre-trains, and the simulation of every pre-trained
// pose is shared among the ranks; rank 0 logs and writes.

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/learning_jobs.h"
#include "learning_flags.h"
#include "mpi_flags.h"

DECLARE_string(model);
DEFINE_bool(restart, false, "Pre-train anew: not from the checkpoint of an earlier run that "
            "was stopped (with the same model and decoder flags it would resume), and even "
            "where the model's decoder was pre-trained with these flags (kept otherwise) or "
            "trained since (refused otherwise).");

int main(int argc, char** argv) {
  aqs::InitApp("Pre-train the decoder of a prepared model.\n"
               "  aqs_pretrain --model=MODEL [--latent_dim=16 --hidden=128,128 ...]\n"
               "  mpirun -np N aqs_pretrain ...   (the poses' simulation shared among N ranks)",
               &argc, &argv);
  const std::unique_ptr<aqs::Communicator> ranks = aqs::StartRanks(&argc, &argv);
  aqs::PretrainOptions options;
  aqs::PoseSimulationOptions simulation;
  bool simulate = true;
  std::string error;
  if (FLAGS_model.empty()) error = "--model is required";
  if (!error.empty() || !aqs::PretrainOptionsFromFlags(&options, &error) ||
      !aqs::PretrainSimulationFromFlags(&simulation, &simulate, &error)) {
    aqs::PrintRankError(ranks.get(), error);
    return 1;
  }
  // The training flags a shared flagfile gives pre-training too are checked now, as
  // aqs_pipeline checks every stage's: a bad one would otherwise show only after
  // pre-training, when aqs_train reads it.
  aqs::TrainOptions train;
  if (!aqs::TrainOptionsFromFlags(&train, &error) || !train.Validate(&error)) {
    aqs::PrintRankError(ranks.get(), aqs::FlagError(error, aqs::TrainFlagNames()));
    return 1;
  }
  options.resume = !FLAGS_restart;
  // As aqs_pipeline's pretrain stage: a decoder pre-trained with these flags is kept, and
  // one pre-trained otherwise and trained since is not discarded (a rerun after a stop of
  // a later stage pre-trained anew, and over a trained model deleted its training).
  bool ok = aqs::RunPretrainJob(FLAGS_model, options, simulate ? &simulation : nullptr,
                                std::cout, &error, !FLAGS_restart, ranks.get());
  if (ranks == nullptr) {
    return aqs::FinishJob(ok ? aqs::JobStatus::kOk : aqs::JobStatus::kBadInput, error,
                          aqs::PretrainFlagNames());
  }
  ok = ranks->Agree(ok, &error);  // rank 0's status on every rank; its message once
  if (!ok) aqs::PrintRankError(ranks.get(), aqs::FlagError(error, aqs::PretrainFlagNames()));
  return aqs::ExitStatus(ok ? aqs::JobStatus::kOk : aqs::JobStatus::kBadInput);
}
