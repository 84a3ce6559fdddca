#include "mpi_flags.h"

#include <cstdio>
#include <cstdlib>

#include <gflags/gflags.h>

#include "app_common.h"
#include "dist/mpi_runtime.h"
#include "util/blas.h"

DEFINE_bool(mpi, false, "Run as one rank of an MPI job (docs/distributed.md). Automatic when "
            "mpirun starts the app with more than one process; exit 1 if this build has no MPI.");

namespace aqs {

std::unique_ptr<Communicator> StartRanks(int* argc, char*** argv) {
  const int launched = LauncherWorldSize();
  if (!FLAGS_mpi && launched <= 1) return nullptr;
  std::string error;
  std::unique_ptr<Communicator> communicator = StartMpi(argc, argv, &error);
  if (!communicator) {
    if (launched > 1) {
      error = "started by an MPI launcher as one of " + std::to_string(launched) +
              " processes, but " + error;
    } else {
      error = "--mpi: " + error;
    }
    PrintError(error);
    std::exit(1);
  }
  if (communicator->size() > 1) {
    if (gflags::GetCommandLineFlagInfoOrDie("threads").is_default) {
      gflags::SetCommandLineOption("threads", "1");
    }
    if (std::getenv("OPENBLAS_NUM_THREADS") == nullptr) SetBlasThreads(1);
  }
  return communicator;
}

void PrintRankError(const Communicator* communicator, const std::string& message) {
  if (communicator == nullptr || communicator->is_root()) {
    PrintError(message);
  }
}

}  // namespace aqs
