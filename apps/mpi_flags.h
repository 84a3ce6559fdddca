#ifndef AQS_APPS_MPI_FLAGS_H_
#define AQS_APPS_MPI_FLAGS_H_

#include <memory>
#include <string>

#include "dist/communicator.h"

namespace aqs {

// The ranks of this run (apps that run over MPI: aqs_train, aqs_pipeline,
// aqs_evaluate, aqs_fit --sequence, aqs_bench_mpi; docs/distributed.md). MPI starts
// when --mpi is set or an MPI launcher (mpirun) started the process
// (dist/mpi_runtime.h, LauncherWorldSize); then returns the job's communicator, else
// null (one process, MPI untouched). Exits with status 1 and a message if MPI is wanted (--mpi, or
// mpirun with more than one process) but this build has no MPI, or it fails to start.
// With more than one rank: each rank runs one thread unless --threads is given, and
// BLAS one thread unless OPENBLAS_NUM_THREADS is set.
std::unique_ptr<Communicator> StartRanks(int* argc, char*** argv);

// PrintError(message) on rank 0 only (or without ranks): the ranks of a distributed
// job agree on failures, and rank 0 has the message.
void PrintRankError(const Communicator* communicator, const std::string& message);

}  // namespace aqs

#endif  // AQS_APPS_MPI_FLAGS_H_
