#ifndef AQS_DIST_MPI_RUNTIME_H_
#define AQS_DIST_MPI_RUNTIME_H_

#include <memory>
#include <string>

#include "dist/communicator.h"

namespace aqs {

// MPI for distributed runs (docs/distributed.md). Built in when CMake's AQS_WITH_MPI
// found an MPI (Open MPI, the Debian packages libopenmpi-dev and openmpi-bin); without
// it, StartMpi fails with a message saying so, and everything else works in one
// process.

// Whether this ActiveQS was built with MPI.
bool MpiBuilt();

// The number of processes of the MPI job that launched this process, from the
// launcher's environment (Open MPI's mpirun: OMPI_COMM_WORLD_SIZE; MPICH's Hydra:
// PMI_SIZE), or 0 if no MPI launcher started it.
int LauncherWorldSize();

// Starts MPI (MPI_Init_thread with MPI_THREAD_FUNNELED: only the calling thread makes
// MPI calls) and returns the communicator of all the job's processes (MPI_COMM_WORLD);
// destroying it waits (asleep) for every rank to destroy theirs, then finalizes MPI.
// Once per process. Each collective first waits for all ranks by polling a
// non-blocking barrier with sleeps of up to 1 ms, then runs the blocking MPI
// collective, so that a rank waiting for others (for rank 0's checkpoint, a slower
// rank's poses, the other stages of a pipeline) leaves the processor to them, also
// when ranks share cores. MPI errors abort the whole job (MPI's default handler):
// never a hang. Returns null with *error if MPI is not built in or does not start.
std::unique_ptr<Communicator> StartMpi(int* argc, char*** argv, std::string* error);

}  // namespace aqs

#endif  // AQS_DIST_MPI_RUNTIME_H_
