// aqs_pipeline: the stages from one flagfile: prepare, pre-train, train, evaluate. Every stage's flags are accepted; --stages picks which run.
// A stage that fails stops the pipeline with its message and exit status 1.

#include <filesystem>
#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/learning_jobs.h"
#include "evaluate_flags.h"
#include "learning_flags.h"
#include "model/model_directory.h"
#include "prepare_flags.h"
#include "util/wall_timer.h"

DECLARE_string(model);
DEFINE_string(stages, "prepare,pretrain,train,evaluate", "Stages to run, in order.");
DEFINE_bool(restart, false, "Train: ignore an earlier run's iteration count.");

int main(int argc, char** argv) {
  aqs::InitApp("Run the ActiveQS stages from one flagfile.\n"
               "  aqs_pipeline --flagfile=configs/face_demo.flags [--stages=prepare,pretrain,train]",
               &argc, &argv);
  aqs::WallTimer total;
  std::string error;
  const std::vector<std::string> stages = aqs::SplitCommaList(FLAGS_stages);
  // The stages that write the model run under one hold of its writers' lock.
  bool writes = false, prepares = false;
  for (const std::string& stage : stages) {
    writes |= stage == "prepare" || stage == "pretrain" || stage == "train";
    prepares |= stage == "prepare";
  }
  aqs::PathLock lock;
  if (writes && !FLAGS_model.empty()) {
    std::string model = FLAGS_model;
    while (model.size() > 1 && model.back() == '/') model.pop_back();
    const std::filesystem::path parent =
        std::filesystem::absolute(model).lexically_normal().parent_path();
    std::error_code code;
    if (prepares) std::filesystem::create_directories(parent, code);
    if (std::filesystem::is_directory(parent, code) &&
        !aqs::LockModelForWriting(model, &std::cout, &lock, &error)) {
      aqs::PrintError(error);
      return 1;
    }
  }
  for (const std::string& stage : stages) {
    std::cout << "=== " << stage << "\n" << std::flush;
    aqs::WallTimer timer;
    bool ok = false;
    if (stage == "prepare") {
      aqs::PrepareJobOptions options;
      ok = aqs::PrepareOptionsFromFlags(&options, &error) &&
           aqs::RunPrepareJob(options, std::cout, &error);
    } else if (stage == "pretrain") {
      aqs::PretrainOptions options;
      aqs::PoseSimulationOptions simulation;
      bool simulate = true;
      ok = aqs::PretrainOptionsFromFlags(&options, &error) &&
           aqs::PretrainSimulationFromFlags(&simulation, &simulate, &error) &&
           aqs::RunPretrainJob(FLAGS_model, options, simulate ? &simulation : nullptr, std::cout,
                               &error);
    } else if (stage == "train") {
      aqs::TrainOptions options;
      ok = aqs::TrainOptionsFromFlags(&options, &error) &&
           aqs::RunTrainJob(FLAGS_model, options, FLAGS_restart, std::cout, &error);
    } else if (stage == "evaluate") {
      aqs::EvaluateJobOptions options;
      std::vector<aqs::EvaluationRow> rows;
      ok = aqs::EvaluateOptionsFromFlags(&options, &error) &&
           aqs::RunEvaluateJob(options, std::cout, &rows, &error);
    } else {
      error = "unknown stage '" + stage + "' (known: prepare, pretrain, train, evaluate)";
    }
    if (!ok) {
      aqs::PrintError(stage + ": " + error);
      return 1;
    }
    std::cout << "=== " << stage << " done in " << timer.Seconds() << " s\n";
  }
  std::cout << "pipeline done in " << total.Seconds() << " s\n";
  return 0;
}
