// aqs_pipeline: the stages from one flagfile: prepare, pre-train, train, evaluate. Every
// stage's flags are accepted; --stages picks which run (jobs/pipeline_stages.h).
// Run again after a stop, it goes on: prepare and pre-training keep a model made from the
// same inputs and flags (--restart: anew), training and the evaluation resume.
// A stage that fails stops the pipeline with its message and its exit status: 1 bad
// input, 2 prepare's embedded simulation did not converge (its model is written). Under
// mpirun (or with --mpi; docs/distributed.md) rank 0 prepares and pre-trains, and shares
// the per-pose simulations of both (prepare's targets, pre-training's simulation of every
// pose) with the other ranks; training shares the poses among all ranks, and the
// evaluation's fits of held-out poses are shared too; rank 0 alone logs and writes.

#include <algorithm>
#include <filesystem>
#include <iostream>
#include <sstream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/learning_jobs.h"
#include "jobs/pipeline_stages.h"
#include "evaluate_flags.h"
#include "learning_flags.h"
#include "mpi_flags.h"
#include "prepare_flags.h"
#include "util/input_file.h"
#include "util/wall_timer.h"

DECLARE_string(model);
DEFINE_string(stages, "prepare,pretrain,train,evaluate", "Stages to run, in order.");
DEFINE_bool(restart, false, "Start anew: prepare and pre-train again even where the model at "
            "--model was made from the same inputs and flags (without it they are kept, so "
            "that a rerun after a stop goes on), pre-train from the start, not from a stopped "
            "run's checkpoint, and train: ignore an earlier run's iteration count.");

namespace {

// The options of one stage, read from the flags.
struct StageOptions {
  aqs::FlagNames flags;  // the stage's field names -> flags, for messages
  aqs::PrepareJobOptions prepare;
  aqs::PretrainOptions pretrain;
  aqs::PoseSimulationOptions simulation;
  bool simulate = true;
  aqs::TrainOptions train;
  aqs::ExpectedDecoder expected;
  aqs::EvaluateJobOptions evaluate;
};

// Reads `stage`'s options from the flags into *o. With `validate`, also checks them as
// the stage's job would (and evaluate's output folder), before any stage runs.
bool ReadStageOptions(const std::string& stage, bool validate, StageOptions* o,
                      std::string* error) {
  if (stage == "prepare") {
    o->flags = aqs::PrepareFlagNames();
    o->prepare.keep_same_model = !FLAGS_restart;
    return aqs::PrepareOptionsFromFlags(&o->prepare, error) &&
           (!validate || o->prepare.Validate(error));
  }
  if (stage == "pretrain") {
    o->flags = aqs::PretrainFlagNames();
    o->pretrain.resume = !FLAGS_restart;
    return aqs::PretrainOptionsFromFlags(&o->pretrain, error) &&
           aqs::PretrainSimulationFromFlags(&o->simulation, &o->simulate, error) &&
           (!validate || (o->pretrain.Validate(error) &&
                          (!o->simulate || o->simulation.Validate(error))));
  }
  if (stage == "train") {
    o->flags = aqs::TrainFlagNames();
    return aqs::TrainOptionsFromFlags(&o->train, error) &&
           aqs::ExpectedDecoderFromFlags(&o->expected, error) &&
           (!validate || o->train.Validate(error));
  }
  o->flags = aqs::EvaluateFlagNames();
  if (!aqs::EvaluateOptionsFromFlags(&o->evaluate, error)) return false;
  if (!validate) return true;
  const std::string& dir = o->evaluate.output_directory;
  std::error_code code;
  if (std::filesystem::exists(dir, code) && !std::filesystem::is_directory(dir, code)) {
    *error = "--output_dir: " + dir + " is a file, not a folder";
    return false;
  }
  return o->evaluate.Validate(error) && aqs::CheckOutputApart(dir, o->evaluate.model, error);
}

}  // namespace

int main(int argc, char** argv) {
  aqs::InitApp("Run the ActiveQS stages from one flagfile.\n"
               "  aqs_pipeline --flagfile=configs/face_demo.flags "
               "[--stages=prepare,pretrain,train,evaluate]",
               &argc, &argv);
  const std::unique_ptr<aqs::Communicator> ranks = aqs::StartRanks(&argc, &argv);
  const bool root = ranks == nullptr || ranks->is_root();
  std::ostringstream quiet;  // the other ranks' log
  std::ostream& out = root ? std::cout : quiet;
  aqs::WallTimer total;
  std::string error;
  aqs::PipelineStages plan;
  // Every stage is checked before the first runs: a typo after "prepare" must not be
  // found only once prepare has replaced a trained model.
  {
    if (!aqs::ParsePipelineStages(aqs::SplitList(FLAGS_stages), &plan, &error)) {
      aqs::PrintRankError(ranks.get(), error);
      return 1;
    }
    // And every stage's flags: a bad training flag must not wait for prepare and
    // pre-training to finish. On rank 0, which alone reads prepare's and pre-training's
    // inputs; the other ranks agree with it.
    bool ok = true;
    if (FLAGS_model.empty()) {  // prepare and evaluate say so themselves
      for (const char* stage : {"pretrain", "train"}) {
        if (ok && std::find(plan.stages.begin(), plan.stages.end(), stage) != plan.stages.end()) {
          error = std::string(stage) + ": --model is required";
          ok = false;
        }
      }
    }
    for (size_t k = 0; root && ok && k < plan.stages.size(); ++k) {
      StageOptions options;
      if (!ReadStageOptions(plan.stages[k], true, &options, &error)) {
        error = plan.stages[k] + ": " + aqs::FlagError(error, options.flags);
        ok = false;
      }
    }
    if (ranks != nullptr) ok = ranks->Agree(ok, &error);
    if (!ok) {
      aqs::PrintRankError(ranks.get(), error);
      return 1;
    }
  }
  // The stages that write the model run under one hold of its writers' lock.
  aqs::PathLock lock;
  bool locked = !root || aqs::LockPipelineModel(plan, FLAGS_model, &std::cout, &lock, &error);
  if (ranks != nullptr) locked = ranks->Agree(locked, &error);
  if (!locked) {
    aqs::PrintRankError(ranks.get(), error);
    return 1;
  }
  // A rerun of the same command after a stop keeps what is done and goes on.
  out << "pipeline: stages " << FLAGS_stages
      << (FLAGS_restart ? " from the start (--restart)"
                        : "; a model made from the same inputs and flags is kept, and stopped "
                          "work resumes (--restart: start anew)")
      << "\n";
  for (const std::string& stage : plan.stages) {
    out << "=== " << stage << "\n" << std::flush;
    aqs::WallTimer timer;
    bool ok = false;
    aqs::JobStatus status = aqs::JobStatus::kBadInput;  // when not ok
    StageOptions options;
    const aqs::FlagNames& flags = options.flags;
    // Every rank reads the stage's options (files another machine may see otherwise:
    // evaluate's --test_poses) and the ranks agree before the stage's collectives.
    bool read = !root && stage == "prepare"
                    ? aqs::PrepareTargetOptionsFromFlags(&options.prepare, &error)
                    : ReadStageOptions(stage, false, &options, &error);
    if (ranks != nullptr) read = ranks->Agree(read, &error);
    if (!read) {
      aqs::PrintRankError(ranks.get(), stage + ": " + aqs::FlagError(error, flags));
      return 1;
    }
    if (!root && stage == "prepare") {
      // Rank 0 reads the inputs; this rank makes a share of the targets.
      options.prepare.communicator = ranks.get();
      ok = aqs::RunPrepareJob(options.prepare, out, &error, &status);
    } else if (stage == "prepare") {
      options.prepare.communicator = ranks.get();
      ok = aqs::RunPrepareJob(options.prepare, std::cout, &error, &status);
    } else if (stage == "pretrain") {
      ok = aqs::RunPretrainJob(FLAGS_model, options.pretrain,
                               options.simulate ? &options.simulation : nullptr, out, &error,
                               !FLAGS_restart, ranks.get());
    } else if (stage == "train") {
      options.train.communicator = ranks.get();
      ok = aqs::RunTrainJob(FLAGS_model, options.train, FLAGS_restart, out, &error,
                            options.expected);
    } else {
      std::vector<aqs::EvaluationRow> rows;
      options.evaluate.communicator = ranks.get();
      ok = aqs::RunEvaluateJob(options.evaluate, out, &rows, &error);
    }
    // Every rank stops where one fails (train and evaluate agree inside; prepare and
    // pretrain report rank 0's status here).
    if (ranks != nullptr) {
      ok = ranks->Agree(ok, &error);
      int code = static_cast<int>(status);  // rank 0's: the same exit status everywhere
      ranks->Broadcast(&code, 1, 0);
      status = static_cast<aqs::JobStatus>(code);
    }
    if (!ok) {
      // A stage that did not converge (prepare: exit 2, its model written) stops the
      // later ones too: they would build on it.
      aqs::PrintRankError(ranks.get(), stage + ": " + aqs::FlagError(error, flags));
      return aqs::ExitStatus(status == aqs::JobStatus::kOk ? aqs::JobStatus::kBadInput : status);
    }
    out << "=== " << stage << " done in " << timer.Seconds() << " s\n";
  }
  out << "pipeline done in " << total.Seconds() << " s\n";
  return 0;
}
