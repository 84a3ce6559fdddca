#include "mpi_flags.h"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <gflags/gflags.h>

#include "app_common.h"
#include "dist/mpi_runtime.h"
#include "util/blas.h"

DEFINE_bool(mpi, false, "Run as one rank of an MPI job (docs/distributed.md). Automatic when "
            "mpirun starts the app with more than one process; exit 1 if this build has no MPI.");

namespace aqs {
namespace {

// Whether every rank was given the same ActiveQS flags (those defined in apps/, the
// folder of this file; defaults included, --mpi not) as rank 0: false on every rank
// with *error naming the lowest rank's first flag that differs. Ranks with other flags
// would train or fit other problems, or (one refusing a flag the others took) wait
// for each other forever.
bool SameFlagsOnEveryRank(const Communicator& communicator, std::string* error) {
  const std::string here = __FILE__;
  const std::string apps_folder = here.substr(0, here.rfind('/') + 1);
  std::vector<gflags::CommandLineFlagInfo> all;
  gflags::GetAllFlags(&all);
  std::vector<std::string> items;
  for (const gflags::CommandLineFlagInfo& info : all) {
    if (info.filename.rfind(apps_folder, 0) != 0 || info.name == "mpi") continue;
    std::string value = info.current_value;
    std::replace(value.begin(), value.end(), '\n', ' ');
    items.push_back("--" + info.name + "=" + value);
  }
  std::sort(items.begin(), items.end());
  const int unlike = communicator.FirstItemUnlikeRoot(items);
  if (unlike >= 0) {
    *error = (unlike < static_cast<int>(items.size()) ? items[unlike] : std::string("its flags")) +
             " differs from rank 0's: every rank must be given the same flags";
  }
  return communicator.Agree(unlike < 0, error);
}

}  // namespace

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
    if (!SameFlagsOnEveryRank(*communicator, &error)) {
      PrintRankError(communicator.get(), error);
      communicator.reset();  // every rank finalizes MPI, then exits
      std::exit(1);
    }
  }
  return communicator;
}

void PrintRankError(const Communicator* communicator, const std::string& message) {
  if (communicator == nullptr || communicator->is_root()) {
    PrintError(message);
  }
}

}  // namespace aqs
