// aqs_kill_at: runs aqs_train's library call (or, with "pretrain", aqs_pretrain's, with
// the synthetic bar's options of testing/training_fixtures.h, one thread and a
// checkpoint every iteration; "pretrain_restart": the same as aqs_pretrain --restart
// runs it, not resuming) in a fresh process that kills itself with SIGKILL (as
// kill -9 would) the N-th time it reaches a util/fault_injection.h point. For tests of
// training under kill -9: a fresh process, because the solver's OpenMP thread pool does
// not survive fork() without exec.
//
//   aqs_kill_at POINT OCCURRENCE MODEL ITERATIONS [pretrain|pretrain_restart]
//
// Exit status: killed by SIGKILL at the point; 0 if training finished first; 1 if it
// failed; 2 on bad arguments.

#include <signal.h>

#include <cstdlib>
#include <iostream>
#include <string>

#include "jobs/learning_jobs.h"
#include "testing/training_fixtures.h"
#include "util/fault_injection.h"

namespace {

std::string g_point;
int g_countdown = 0;

void KillAtPoint(const char* point) {
  if (g_point == point && g_countdown-- == 0) ::raise(SIGKILL);
}

}  // namespace

int main(int argc, char** argv) {
  const bool restart = argc == 6 && std::string(argv[5]) == "pretrain_restart";
  const bool pretrain = restart || (argc == 6 && std::string(argv[5]) == "pretrain");
  if (argc != 5 && !pretrain) {
    std::cerr << "usage: aqs_kill_at POINT OCCURRENCE MODEL ITERATIONS "
                 "[pretrain|pretrain_restart]\n";
    return 2;
  }
  g_point = argv[1];
  g_countdown = std::atoi(argv[2]);
  aqs::SetFaultHookForTesting(&KillAtPoint);
  if (pretrain) {
    aqs::testing::SyntheticBarSpec spec;
    spec.pretrain_iterations = std::atoi(argv[4]);
    spec.num_threads = 1;
    aqs::PretrainOptions options = aqs::testing::SyntheticPretrainOptions(spec);
    options.checkpoint_seconds = 0.0;
    options.resume = !restart;
    std::string error;
    if (!aqs::RunPretrainJob(argv[3], options, nullptr, std::cout, &error)) {
      std::cerr << "aqs_kill_at: " << error << "\n";
      return 1;
    }
    return 0;
  }
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
