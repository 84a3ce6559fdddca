#include "evaluate_flags.h"

#include <gflags/gflags.h>

#include "app_common.h"

#include "prepare/pose_files.h"

DEFINE_string(test_poses, "", "Held-out pose surfaces (folder, glob, .txt list or comma list), "
              "with the neutral's vertex order.");
DEFINE_string(test_exclude, "", "Glob on file names to leave out of --test_poses.");
DEFINE_string(output_dir, "", "Where the evaluation writes evaluation.md, evaluation.csv, "
              "fields/*.ply (per-vertex errors) and fitted/*.obj.");
DEFINE_string(error_vertices, "", "Surface vertices to measure errors on, e.g. 0:9409 "
              "(default: all).");
DEFINE_int32(baseline_iterations, 500, "L-BFGS iterations of the auto-encoder baseline.");
DEFINE_int32(evaluate_fit_iterations, 30, "Levenberg-Marquardt iterations of held-out fits.");
DEFINE_bool(write_fields, true, "Write per-vertex error fields and fitted surfaces.");
DECLARE_string(model);
DECLARE_string(pose_dir);
DECLARE_int32(threads);
DECLARE_double(latent_regularization);

namespace aqs {

bool EvaluateOptionsFromFlags(EvaluateJobOptions* options, std::string* error) {
  if (FLAGS_model.empty() || FLAGS_output_dir.empty()) {
    *error = "--model and --output_dir are required";
    return false;
  }
  options->model = FLAGS_model;
  options->output_directory = FLAGS_output_dir;
  if (!FLAGS_test_poses.empty() &&
      !ResolvePosePaths(FLAGS_test_poses, FLAGS_test_exclude, &options->test_paths, error,
                        FLAGS_pose_dir)) {
    return false;
  }
  if (!FLAGS_error_vertices.empty() &&
      !ParseVertexRanges(FLAGS_error_vertices, &options->error_vertices, error)) {
    return false;
  }
  options->fit.latent_regularization = FLAGS_latent_regularization;
  options->fit.max_iterations = FLAGS_evaluate_fit_iterations;
  options->fit.num_threads = FLAGS_threads;
  if (!SolverMethodFromFlag(&options->fit.solver, error)) return false;
  options->autoencoder.latent_regularization = FLAGS_latent_regularization;
  options->autoencoder.max_iterations = FLAGS_baseline_iterations;
  options->write_fields = FLAGS_write_fields;
  options->num_threads = FLAGS_threads;
  return true;
}

}  // namespace aqs
