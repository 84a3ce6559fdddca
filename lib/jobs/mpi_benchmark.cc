#include "jobs/mpi_benchmark.h"

#include <algorithm>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "dist/model_sharing.h"
#include "model/model_io.h"
#include "util/machine_info.h"
#include "util/option_checks.h"
#include "util/string_format.h"
#include "util/wall_timer.h"

namespace aqs {

bool MpiBenchmarkOptions::Validate(std::string* error) const {
  std::string train_error;
  const bool train_ok = train.Validate(&train_error);
  return OptionChecks()
      .Require(!model.empty(), "model is required")
      .IntAtLeast("iterations", iterations, 1)
      .IntAtLeast("repeats", repeats, 1)
      .IntAtLeast("reduction_calls", reduction_calls, 1)
      .Nested("train", train_ok, train_error)
      .Done(error);
}

double MpiTrainingRun::SecondsPerIteration() const {
  return evaluation_seconds / std::max(1, iterations);
}

double MpiTrainingRun::SecondsPerEvaluation() const {
  return evaluation_seconds / std::max(1, evaluations);
}

namespace {

// Training of a copy of `model` on the ranks of `communicator` (null: this process).
bool Train(const MpiBenchmarkOptions& options, const ActiveModel& model,
           const Communicator* communicator, MpiTrainingRun* run, std::string* error) {
  ActiveModel copy = model;
  TrainOptions train = options.train;
  train.max_iterations = options.iterations;
  train.max_restarts = 0;
  train.log_every = 0;
  train.communicator = communicator;
  TrainReport report;
  std::ostringstream log;
  WallTimer timer;
  const double cpu = ProcessCpuSeconds();
  if (!TrainEndToEnd(train, &copy, &report, log, error)) return false;
  run->wall_seconds = timer.Seconds();
  run->cpu_seconds = ProcessCpuSeconds() - cpu;
  run->iterations = report.iterations;
  run->evaluations = report.iteration_cost.evaluations;
  run->evaluation_seconds = report.iteration_cost.seconds;
  return true;
}

// Median and best of `calls` timed calls of `body` (after 2 untimed ones), all ranks
// starting each call together.
template <typename Body>
std::pair<double, double> TimeCalls(const Communicator& world, int calls, Body body) {
  std::vector<double> seconds;
  for (int i = 0; i < calls + 2; ++i) {
    world.Barrier();
    WallTimer timer;
    body();
    if (i >= 2) seconds.push_back(timer.Seconds());
  }
  std::sort(seconds.begin(), seconds.end());
  return {seconds[seconds.size() / 2], seconds.front()};
}

}  // namespace

JobStatus RunMpiBenchmark(const MpiBenchmarkOptions& options, const Communicator* ranks,
                          std::ostream& out, std::string* error) {
  if (!options.Validate(error)) return JobStatus::kBadInput;
  const LocalCommunicator local;
  const Communicator& world = ranks != nullptr ? *ranks : local;
  const bool root = world.is_root();
  ActiveModel model;
  bool ok = LoadModel(options.model, &model, error);
  if (ok && !model.decoder) {
    *error = options.model + ": the model is not pre-trained (no decoder)";
    ok = false;
  }
  if (!ShareModel(world, options.model, ok, &model, error)) return JobStatus::kBadInput;
  const int n = world.size();
  if (root) {
    out << BenchmarkMachineLine() << " (before)\n";
    out << StringPrintf("model %s: %d elements, %d poses, %d decoder parameters; %s, %d "
                        "thread(s) per rank\n",
                        options.model.c_str(), model.mesh.num_tets(), model.num_poses(),
                        model.decoder->num_parameters(), world.Description().c_str(),
                        options.train.num_threads);
    out << StringPrintf("%-8s %6s %6s %9s %9s %9s %9s\n", "ranks", "iters", "evals", "s/iter",
                        "s/eval", "wall s", "cpu s");
  }
  MpiTrainingRun best_one, best_all;
  for (int repeat = 0; repeat < options.repeats; ++repeat) {
    for (const bool alone : {true, false}) {
      if (!alone && n == 1) continue;  // all ranks are rank 0 alone
      MpiTrainingRun run;
      run.ranks = alone ? 1 : n;
      ok = true;
      if (alone) {
        if (root) ok = Train(options, model, nullptr, &run, error);
        ok = world.Agree(ok, error);  // the others wait here
      } else {
        ok = Train(options, model, ranks, &run, error);
        ok = world.Agree(ok, error);
        world.MaxToAll(&run.cpu_seconds, 1);
      }
      if (!ok) return JobStatus::kNotConverged;
      if (!root) continue;
      out << StringPrintf("%-8d %6d %6d %9.3f %9.3f %9.2f %9.2f\n", run.ranks, run.iterations,
                          run.evaluations, run.SecondsPerIteration(),
                          run.SecondsPerEvaluation(), run.wall_seconds, run.cpu_seconds);
      out.flush();
      MpiTrainingRun& best = alone ? best_one : best_all;
      if (best.evaluations == 0 || run.SecondsPerEvaluation() < best.SecondsPerEvaluation()) {
        best = run;
      }
    }
  }
  if (root && n > 1) {
    const double per_evaluation = best_one.SecondsPerEvaluation() / best_all.SecondsPerEvaluation();
    const double per_iteration = best_one.SecondsPerIteration() / best_all.SecondsPerIteration();
    const double from_cpu = best_one.cpu_seconds / best_all.cpu_seconds;
    out << StringPrintf("best runs: %d ranks vs 1: speed-up %.3f per evaluation (efficiency "
                        "%.1f%%), %.3f per iteration (efficiency %.1f%%); from the busiest rank's "
                        "processor time %.3f (efficiency %.1f%%: the figure of an otherwise idle "
                        "machine, less its waits)\n",
                        n, per_evaluation, 100.0 * per_evaluation / n, per_iteration,
                        100.0 * per_iteration / n, from_cpu, 100.0 * from_cpu / n);
  }
  // The reductions of one evaluation, on vectors of the decoder's size and of the whole
  // training vector.
  const int decoder_size = model.decoder->num_parameters();
  const int training_size = decoder_size + static_cast<int>(model.latents.size());
  if (root) {
    out << StringPrintf("%-28s %10s %10s %10s %10s\n", "reduction", "doubles", "median ms",
                        "best ms", "GB/s");
  }
  const int calls = options.reduction_calls;
  for (const int count : {decoder_size, training_size}) {
    std::vector<double> data(count, 1.0);
    const std::pair<std::string, std::pair<double, double>> timings[3] = {
        {"SumToRoot (gradient)",
         TimeCalls(world, calls, [&] { world.SumToRoot(data.data(), count); })},
        {"SumToAll", TimeCalls(world, calls, [&] { world.SumToAll(data.data(), count); })},
        {"Broadcast (parameters)",
         TimeCalls(world, calls, [&] { world.Broadcast(data.data(), count, 0); })}};
    if (!root) continue;
    for (const auto& t : timings) {
      const double median = std::max(t.second.first, 1e-12);
      out << StringPrintf("%-28s %10d %10.3f %10.3f %10.2f\n", t.first.c_str(), count,
                          1e3 * t.second.first, 1e3 * t.second.second, 8.0 * count / median / 1e9);
    }
  }
  if (root) out << "load average " << LoadAverage() << " (after)\n";
  out.flush();
  return JobStatus::kOk;
}

}  // namespace aqs
