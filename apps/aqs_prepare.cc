// aqs_prepare: from a neutral surface and pose surfaces, build a model directory:
// simulation mesh, boundary conditions (static and bone-driven), the embedding of the
// surface, and per-pose volumetric targets by embedded simulation.
// It replaces only a missing path, an empty folder or an ActiveQS model unless
// --overwrite, and holds the model's writers' lock (docs/model_format.md, "Writing").
// Exit status: 0 done; 1 bad input (the message says which file or flag), an output
// that is not a model, a model another process is writing, or a lattice or simulation
// above --max_memory_gb; 2 the embedded simulation of some poses did not converge (the
// model is written, for inspection). Under mpirun (or with --mpi; docs/distributed.md)
// rank 0 reads the inputs and does the job, and the volumetric targets' embedded
// simulations are shared among the ranks; rank 0 logs and writes.

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "mpi_flags.h"
#include "prepare_flags.h"

DEFINE_bool(restart, false, "Prepare anew even where the model at --model is the model of "
            "these inputs and flags (kept otherwise, with its learned state) or holds a "
            "learned state that preparing anew discards (refused otherwise).");

int main(int argc, char** argv) {
  aqs::InitApp(
      "Prepare an active model from surface poses.\n"
      "  aqs_prepare --neutral=N.obj --poses=DIR --model=MODEL --spacing=H [--shell=T]\n"
      "              [--fixed_depth=D | --fixed_box=... | --fixed_inside=... | --fixed_list=...]\n"
      "              [--bone_mesh=B.obj --bone_poses=DIR/{pose}.b.obj --bone_region=BOX]\n"
      "              [--overwrite] [--restart]\n"
      "  mpirun -np N aqs_prepare ...   (the targets' simulations shared among N ranks)",
      &argc, &argv);
  const std::unique_ptr<aqs::Communicator> ranks = aqs::StartRanks(&argc, &argv);
  const bool root = ranks == nullptr || ranks->is_root();
  aqs::PrepareJobOptions options;
  options.communicator = ranks.get();
  std::string error;
  // Rank 0 reads the inputs; the other ranks only need the targets' options.
  bool ok = root ? aqs::PrepareOptionsFromFlags(&options, &error)
                 : aqs::PrepareTargetOptionsFromFlags(&options, &error);
  if (ranks != nullptr) ok = ranks->Agree(ok, &error);
  if (!ok) {
    aqs::PrintRankError(ranks.get(), aqs::FlagError(error, aqs::PrepareFlagNames()));
    return 1;
  }
  // As aqs_pipeline's prepare stage: a rerun keeps the same model with its learned state,
  // and does not discard another's (a rerun of a prepare, pretrain, train script after a
  // stop deleted the training).
  options.keep_same_model = !FLAGS_restart;
  aqs::JobStatus status = aqs::JobStatus::kOk;
  ok = aqs::RunPrepareJob(options, std::cout, &error, &status);
  if (ranks == nullptr) return aqs::FinishJob(status, error, aqs::PrepareFlagNames());
  // Rank 0's status on every rank; its message once.
  ok = ranks->Agree(ok, &error);
  int code = static_cast<int>(status);
  ranks->Broadcast(&code, 1, 0);
  status = static_cast<aqs::JobStatus>(code);
  if (ok) return 0;
  aqs::PrintRankError(ranks.get(), aqs::FlagError(error, aqs::PrepareFlagNames()));
  return aqs::ExitStatus(status == aqs::JobStatus::kOk ? aqs::JobStatus::kBadInput : status);
}
