// aqs_prepare: from a neutral surface and pose surfaces, build a model directory:
// simulation mesh, boundary conditions (static and bone-driven), the embedding of the
// surface, and per-pose volumetric targets by embedded simulation.
// It replaces only a missing path, an empty folder or an ActiveQS model unless
// --overwrite, and holds the model's writers' lock (docs/model_format.md, "Writing").
// Exit status: 0 done; 1 bad input (the message says which file or flag), an output
// that is not a model, a model another process is writing, or a lattice or simulation
// above --max_memory_gb; 2 the embedded simulation of some poses did not converge (the
// model is written, for inspection).

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "prepare_flags.h"

int main(int argc, char** argv) {
  aqs::InitApp(
      "Prepare an active model from surface poses.\n"
      "  aqs_prepare --neutral=N.obj --poses=DIR --model=MODEL --spacing=H [--shell=T]\n"
      "              [--fixed_depth=D | --fixed_box=... | --fixed_inside=... | --fixed_list=...]\n"
      "              [--bone_mesh=B.obj --bone_poses=DIR/{pose}.b.obj --bone_region=BOX]\n"
      "              [--overwrite]",
      &argc, &argv);
  aqs::PrepareJobOptions options;
  std::string error;
  if (!aqs::PrepareOptionsFromFlags(&options, &error)) {
    aqs::PrintError(error);
    return 1;
  }
  aqs::JobStatus status = aqs::JobStatus::kOk;
  aqs::RunPrepareJob(options, std::cout, &error, &status);
  return aqs::FinishJob(status, error, aqs::PrepareFlagNames());
}
