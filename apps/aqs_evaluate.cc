// aqs_evaluate: per-pose errors of the physics model and of two surface-only baselines
// of the same latent size (an auto-encoder, PCA) on training and held-out poses, as
// Markdown and CSV tables and per-vertex error fields (PLY).
// Exit status: 0 done; 1 bad input.

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "evaluate_flags.h"

int main(int argc, char** argv) {
  aqs::InitApp("Evaluate a trained model against surface-only baselines.\n"
               "  aqs_evaluate --model=MODEL --test_poses=SPEC --output_dir=DIR",
               &argc, &argv);
  aqs::EvaluateJobOptions options;
  std::vector<aqs::EvaluationRow> rows;
  std::string error;
  if (!aqs::EvaluateOptionsFromFlags(&options, &error) ||
      !aqs::RunEvaluateJob(options, std::cout, &rows, &error)) {
    aqs::PrintError(error);
    return 1;
  }
  return 0;
}
