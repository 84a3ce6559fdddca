// aqs_kill_at: runs aqs_train's library call in a fresh process that kills itself with
// SIGKILL (as kill -9 would) the N-th time it reaches a util/fault_injection.h point.
// For tests of training under kill -9: a fresh process, because the solver's OpenMP
// thread pool does not survive fork() without exec.
//
//   aqs_kill_at POINT OCCURRENCE MODEL ITERATIONS
//
// Exit status: killed by SIGKILL at the point; 0 if training finished first; 1 if it
// failed; 2 on bad arguments.

#include <signal.h>

#include <cstdlib>
#include <iostream>
#include <string>

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
  if (argc != 5) {
    std::cerr << "usage: aqs_kill_at POINT OCCURRENCE MODEL ITERATIONS\n";
    return 2;
  }
  g_point = argv[1];
  g_countdown = std::atoi(argv[2]);
  aqs::SetFaultHookForTesting(&KillAtPoint);
  aqs::TrainOptions options;
  options.max_iterations = std::atoi(argv[4]);
  options.num_threads = 1;
  options.log_every = 0;
  std::string error;
  if (!aqs::RunTrainJob(argv[3], options, false, std::cout, &error)) {
    std::cerr << "aqs_kill_at: " << error << "\n";
    return 1;
  }
  return 0;
}
