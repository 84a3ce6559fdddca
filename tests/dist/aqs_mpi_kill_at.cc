// aqs_mpi_kill_at: aqs_train's library call over MPI, where one rank kills itself with
// SIGKILL (as kill -9 would) the N-th time it reaches a util/fault_injection.h point,
// for tests of a distributed run that loses a rank (mpi_apps_test.cc):
//
//   mpirun -np 2 aqs_mpi_kill_at POINT OCCURRENCE RANK MODEL ITERATIONS
//
// Points: "objective:solved" (a rank's poses solved, in every evaluation), the model
// writing points of util/ (rank 0's checkpoints). Exit status: 0 if training finished
// first; 1 if it failed; 2 on bad arguments; mpirun ends the job when the rank dies.

#include <signal.h>

#include <cstdlib>
#include <iostream>
#include <string>

#include "dist/mpi_runtime.h"
#include "jobs/learning_jobs.h"
#include "util/fault_injection.h"

namespace {

std::string g_point;
int g_countdown = 0;

void KillAtPoint(const char* point) {
  if (g_point == point && g_countdown-- == 0) ::raise(SIGKILL);
}

}  // namespace

int main(int argc, char** argv) {
  std::string error;
  std::unique_ptr<aqs::Communicator> world = aqs::StartMpi(&argc, &argv, &error);
  if (!world) {
    std::cerr << "aqs_mpi_kill_at: " << error << "\n";
    return 1;
  }
  if (argc != 6) {
    std::cerr << "usage: aqs_mpi_kill_at POINT OCCURRENCE RANK MODEL ITERATIONS\n";
    return 2;
  }
  if (world->rank() == std::atoi(argv[3])) {
    g_point = argv[1];
    g_countdown = std::atoi(argv[2]);
    aqs::SetFaultHookForTesting(&KillAtPoint);
  }
  aqs::TrainOptions options;
  options.max_iterations = std::atoi(argv[5]);
  options.num_threads = 1;
  options.log_every = 1;
  options.communicator = world.get();
  if (!aqs::RunTrainJob(argv[4], options, false, std::cout, &error)) {
    if (world->is_root()) std::cerr << "aqs_mpi_kill_at: " << error << "\n";
    return 1;
  }
  return 0;
}
