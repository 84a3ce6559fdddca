// aqs_bench_mpi: strong scaling of end-to-end training over MPI ranks, and the cost of
// the reductions of the decoder's parameter vector (docs/distributed.md).
//
//   mpirun -np N aqs_bench_mpi --model=DIR [--iterations=5] [--repeats=1]
//
// Runs TrainEndToEnd (the training aqs_train does, nothing saved) for --iterations
// L-BFGS iterations from the model's learned state, first on rank 0 alone (the other
// ranks wait, asleep) and then on all N ranks, --repeats times each; every rank has
// --threads threads (default 1 under mpirun) and one BLAS thread. Prints per run the
// iterations, evaluations, seconds per iteration and per evaluation (wall time of the
// evaluations of the L-BFGS iterations, line-search trials included), and then the
// speed-up and parallel efficiency t1 / (N tN) of the best runs, per evaluation and
// per iteration, and from processor time: the busiest rank's processor seconds for the
// whole run against rank 0's alone (on a machine shared with other work, what the wall
// times would be on an idle one, less the ranks' waiting for each other). Then times, over 20 repetitions (median and best), SumToRoot (what an
// evaluation does with the gradient), SumToAll and Broadcast (what each evaluation
// does with the parameters) of a vector of the decoder's parameter count and of the
// whole training vector (decoder parameters and latents). Also prints the machine: cores,
// processor, load average before and after.

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gflags/gflags.h>

#include "app_common.h"
#include "dist/model_sharing.h"
#include "model/model_io.h"
#include "mpi_flags.h"
#include "train/trainer.h"
#include "util/wall_timer.h"

DEFINE_int32(iterations, 5, "L-BFGS iterations per run.");
DEFINE_int32(repeats, 1, "Runs on 1 rank and on all ranks, alternating.");
DEFINE_double(tolerance, 1e-6, "Relative force tolerance of the training equilibria.");
DECLARE_int32(threads);
DECLARE_string(model);

namespace aqs {
namespace {

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  in >> one >> five >> fifteen;
  return one + " " + five + " " + fifteen;
}

std::string Processor() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  }
  return "unknown processor";
}

// Processor seconds this process has used (all its threads).
double CpuSeconds() {
  timespec t;
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}

struct Run {
  int iterations = 0, evaluations = 0;
  double evaluation_seconds = 0, wall = 0;
  double cpu = 0;  // the busiest rank's processor seconds for the whole run
  double per_iteration() const { return evaluation_seconds / std::max(1, iterations); }
  double per_evaluation() const { return evaluation_seconds / std::max(1, evaluations); }
};

// Training on the ranks of `communicator` (null: this process alone).
bool Train(const ActiveModel& model, const Communicator* communicator, Run* run,
           std::string* error) {
  ActiveModel copy = model;
  TrainOptions options;
  options.max_iterations = FLAGS_iterations;
  options.num_threads = FLAGS_threads;
  options.solver.relative_force_tolerance = FLAGS_tolerance;
  if (!SolverMethodFromFlag(&options.solver, error)) return false;
  options.max_restarts = 0;
  options.log_every = 0;
  options.communicator = communicator;
  TrainReport report;
  std::ostringstream log;
  WallTimer timer;
  const double cpu = CpuSeconds();
  if (!TrainEndToEnd(options, &copy, &report, log, error)) return false;
  run->wall = timer.Seconds();
  run->cpu = CpuSeconds() - cpu;
  run->iterations = report.iterations;
  run->evaluations = report.iteration_cost.evaluations;
  run->evaluation_seconds = report.iteration_cost.seconds;
  return true;
}

// Median and best of 20 timed calls of `body` (after 2 untimed ones), all ranks
// starting together.
template <typename Body>
std::pair<double, double> Time(const Communicator& world, Body body) {
  std::vector<double> seconds;
  for (int i = 0; i < 22; ++i) {
    world.Barrier();
    WallTimer timer;
    body();
    if (i >= 2) seconds.push_back(timer.Seconds());
  }
  std::sort(seconds.begin(), seconds.end());
  return {seconds[seconds.size() / 2], seconds.front()};
}

int Main(const Communicator* ranks) {
  const LocalCommunicator local;
  const Communicator& world = ranks != nullptr ? *ranks : local;
  const bool root = world.is_root();
  std::string error;
  bool ok = !FLAGS_model.empty() && FLAGS_iterations >= 1 && FLAGS_repeats >= 1 &&
            FLAGS_threads >= 1 && FLAGS_tolerance > 0;
  if (!ok) {
    PrintRankError(ranks, "--model is required; --iterations, --repeats and --threads must be "
                          ">= 1, --tolerance > 0");
    return 1;
  }
  ActiveModel model;
  ok = LoadModel(FLAGS_model, &model, &error);
  if (ok && !model.decoder) {
    error = FLAGS_model + ": the model is not pre-trained (no decoder)";
    ok = false;
  }
  if (!ShareModel(world, FLAGS_model, ok, &model, &error)) {
    PrintRankError(ranks, error);
    return 1;
  }
  const int n = world.size();
  if (root) {
    char host[256] = "?";
    gethostname(host, sizeof(host));
    std::printf("machine %s: %ld cores, %s; load average %s (before)\n", host,
                sysconf(_SC_NPROCESSORS_ONLN), Processor().c_str(), LoadAverage().c_str());
    std::printf("model %s: %d elements, %d poses, %d decoder parameters; %s, %d thread(s) per "
                "rank\n",
                FLAGS_model.c_str(), model.mesh.num_tets(), model.num_poses(),
                model.decoder->num_parameters(), world.Description().c_str(), FLAGS_threads);
    std::printf("%-8s %6s %6s %9s %9s %9s %9s\n", "ranks", "iters", "evals", "s/iter", "s/eval",
                "wall s", "cpu s");
  }
  Run best_one, best_all;
  for (int repeat = 0; repeat < FLAGS_repeats; ++repeat) {
    for (const bool alone : {true, false}) {
      if (alone && n == 1 && repeat > 0) continue;
      Run run;
      ok = true;
      if (alone) {
        if (root) ok = Train(model, nullptr, &run, &error);
        ok = world.Agree(ok, &error);  // the others wait here
      } else {
        ok = Train(model, ranks, &run, &error);
        if (ranks != nullptr) ok = world.Agree(ok, &error);
        world.MaxToAll(&run.cpu, 1);
      }
      if (!ok) {
        PrintRankError(ranks, error);
        return 2;
      }
      if (!root) continue;
      const int used = alone ? 1 : n;
      std::printf("%-8d %6d %6d %9.3f %9.3f %9.2f %9.2f\n", used, run.iterations,
                  run.evaluations, run.per_iteration(), run.per_evaluation(), run.wall, run.cpu);
      std::fflush(stdout);
      Run& best = alone ? best_one : best_all;
      if (best.evaluations == 0 || run.per_evaluation() < best.per_evaluation()) best = run;
    }
  }
  if (root && n > 1) {
    const double speedup_eval = best_one.per_evaluation() / best_all.per_evaluation();
    const double speedup_iter = best_one.per_iteration() / best_all.per_iteration();
    const double speedup_cpu = best_one.cpu / best_all.cpu;
    std::printf("best runs: %d ranks vs 1: speed-up %.3f per evaluation (efficiency %.1f%%), "
                "%.3f per iteration (efficiency %.1f%%); from the busiest rank's processor "
                "time %.3f (efficiency %.1f%%: the figure of an otherwise idle machine, less "
                "its waits)\n",
                n, speedup_eval, 100.0 * speedup_eval / n, speedup_iter, 100.0 * speedup_iter / n,
                speedup_cpu, 100.0 * speedup_cpu / n);
  }
  // The reductions of one evaluation, on vectors of the decoder's size and of the whole
  // training vector.
  const int decoder_size = model.decoder->num_parameters();
  const int training_size = decoder_size + static_cast<int>(model.latents.size());
  if (root) {
    std::printf("%-28s %10s %10s %10s %10s\n", "reduction", "doubles", "median ms", "best ms",
                "GB/s");
  }
  for (const int count : {decoder_size, training_size}) {
    std::vector<double> data(count, 1.0);
    const std::pair<std::string, std::pair<double, double>> timings[3] = {
        {"SumToRoot (gradient)", Time(world, [&] { world.SumToRoot(data.data(), count); })},
        {"SumToAll", Time(world, [&] { world.SumToAll(data.data(), count); })},
        {"Broadcast (parameters)", Time(world, [&] { world.Broadcast(data.data(), count, 0); })}};
    if (!root) continue;
    for (const auto& t : timings) {
      std::printf("%-28s %10d %10.3f %10.3f %10.2f\n", t.first.c_str(), count,
                  1e3 * t.second.first, 1e3 * t.second.second,
                  8.0 * count / t.second.first / 1e9);
    }
  }
  if (root) std::printf("load average %s (after)\n", LoadAverage().c_str());
  return 0;
}

}  // namespace
}  // namespace aqs

int main(int argc, char** argv) {
  aqs::InitApp("Strong scaling of training over MPI ranks, and the parameter reductions.\n"
               "  mpirun -np N aqs_bench_mpi --model=DIR [--iterations=5] [--repeats=1]",
               &argc, &argv);
  const std::unique_ptr<aqs::Communicator> ranks = aqs::StartRanks(&argc, &argv);
  return aqs::Main(ranks.get());
}
