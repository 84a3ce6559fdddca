// aqs_train: end-to-end training of a pre-trained model through the simulator, with
// progress lines, a CSV log (MODEL/train/log.csv) and checkpoints in the model
// directory: run it again after a kill (kill -9 included) to resume from the last
// checkpoint. It holds the model's writers' lock (docs/model_format.md, "Writing").
// Exit status: 0 done; 1 bad input, a model another process is writing, or a model
// that cannot be simulated.

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/learning_jobs.h"
#include "learning_flags.h"

DECLARE_string(model);
DEFINE_bool(restart, false, "Ignore an earlier run's iteration count (start counting at 0, "
            "with a new log).");

int main(int argc, char** argv) {
  aqs::InitApp("Train a pre-trained model end to end.\n"
               "  aqs_train --model=MODEL [--train_iterations=200 --train_minutes=0 ...]",
               &argc, &argv);
  aqs::TrainOptions options;
  std::string error;
  if (FLAGS_model.empty()) error = "--model is required";
  if (!error.empty() || !aqs::TrainOptionsFromFlags(&options, &error) ||
      !aqs::RunTrainJob(FLAGS_model, options, FLAGS_restart, std::cout, &error)) {
    aqs::PrintError(error);
    return 1;
  }
  return 0;
}
