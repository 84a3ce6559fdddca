#include "evaluate_flags.h"

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include <gflags/gflags.h>

#include "app_common.h"
#include "latent_fit_flags.h"
#include "prepare_flags.h"

#include "prepare/pose_files.h"
#include "util/line_reader.h"
#include "util/vertex_ranges.h"

DEFINE_string(test_poses, "", "Held-out pose surfaces (folder, glob, .txt list or comma list), "
              "with the neutral's vertex order.");
DEFINE_string(test_exclude, "", "Glob on file names to leave out of --test_poses.");
DEFINE_string(output_dir, "", "Where the evaluation writes evaluation.md, evaluation.csv, "
              "fields/*.ply (per-vertex errors) and fitted/*.obj.");
DEFINE_string(error_vertices, "", "Surface vertices to measure errors on, e.g. 0:9409 "
              "(default: all).");
DEFINE_string(baseline_linear_skip, "decoder", "Whether the auto-encoder baseline has a linear "
              "skip beside its network: true, false, or 'decoder': as the model's decoder.");
DEFINE_int32(baseline_iterations, 1000, "L-BFGS iterations of the auto-encoder baseline "
             "(500 left the demo's under-trained).");
DEFINE_string(baseline_hidden, "decoder", "Hidden layer widths of the auto-encoder baseline "
              "(comma-separated), or 'decoder': the same as the model's decoder. A linear "
              "decoder's comparison should keep a network here (a linear auto-encoder is the "
              "PCA about the neutral).");
DEFINE_double(baseline_checkpoint_seconds, 60.0, "The auto-encoder baseline's training saves a "
              "checkpoint (autoencoder_checkpoint/ in --output_dir) at most every this many "
              "seconds of its iterations; a run killed between them resumes from the last "
              "(0: every iteration).");
DEFINE_bool(baseline_lbfgs_scaling, true, "The auto-encoder baseline's L-BFGS scales its initial "
            "inverse Hessian as end-to-end training does (--lbfgs_scaling).");
DEFINE_int32(baseline_seed, 1, "Seed of the auto-encoder baseline's random initial weights "
             "(>= 0; its spread over seeds is the baseline's own noise).");
DEFINE_bool(held_out_starts, true, "Held-out latent fits (physics and auto-encoder alike) start "
            "from the best of the mean training latent and every training pose's latent, by "
            "the fit's objective; false: from the mean training latent (physics: at rest). The "
            "report names each fit's start.");
DEFINE_bool(write_fields, true, "Write per-vertex error fields and fitted surfaces.");
DEFINE_bool(error_budget, true, "Measure the error budget: the training poses' volumetric "
            "targets simulated (the floor), the surface error after pre-training (from the "
            "model), and the held-out poses' own volumetric targets (prepare's embedded "
            "simulation: --attachment_stiffness, --inverted_targets, --prepare_tolerance, "
            "--solver; give the values the model was prepared with).");
DEFINE_bool(report, true, "Write an HTML page with the tables, the error budget, the "
            "training curve and pictures (--output_dir/index.html, images/*.png) by the report "
            "script, run with --python. A missing interpreter or matplotlib is reported and "
            "leaves the tables.");
DEFINE_string(report_script, "", "The report script (default: evaluation_report.py in "
              "share/activeqs/ next to the executable's folder, where the build and the "
              "install put it).");
#ifndef AQS_PYTHON
#define AQS_PYTHON "python3"
#endif
DEFINE_string(python, AQS_PYTHON, "The Python 3 interpreter that runs the report script (it "
              "needs matplotlib and numpy; default: the one the build found).");
DECLARE_string(model);
DECLARE_string(pose_dir);
DECLARE_int32(threads);
DECLARE_double(latent_regularization);
DECLARE_int32(train_restarts);

namespace aqs {
namespace {

// <folder of this executable>/../share/activeqs/evaluation_report.py ("" if the
// executable's path is unknown).
std::string DefaultReportScript() {
  std::error_code code;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", code);
  if (code) return "";
  return (exe.parent_path() / ".." / "share" / "activeqs" / "evaluation_report.py")
      .lexically_normal()
      .string();
}

}  // namespace

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
    *error = "--error_vertices: " + *error;
    return false;
  }
  // The held-out fits take the fit flags of aqs_fit (latent_fit_flags.cc).
  if (!LatentFitOptionsFromFlags(&options->fit, error)) return false;
  options->autoencoder.latent_regularization = FLAGS_latent_regularization;
  if (FLAGS_baseline_iterations < 1) {  // untrained weights would pass for a baseline
    *error = "--baseline_iterations must be >= 1 (is " +
             std::to_string(FLAGS_baseline_iterations) + ")";
    return false;
  }
  options->autoencoder.max_iterations = FLAGS_baseline_iterations;
  // The physics training's restart rule and maximum (--train_restarts).
  options->autoencoder.max_restarts = FLAGS_train_restarts;
  options->autoencoder.lbfgs_scaling = FLAGS_baseline_lbfgs_scaling;
  options->autoencoder.checkpoint_seconds = FLAGS_baseline_checkpoint_seconds;
  if (FLAGS_baseline_seed < 0) {
    *error = "--baseline_seed must be >= 0 (is " + std::to_string(FLAGS_baseline_seed) + ")";
    return false;
  }
  options->autoencoder.seed = static_cast<unsigned>(FLAGS_baseline_seed);
  if (FLAGS_baseline_linear_skip == "true" || FLAGS_baseline_linear_skip == "false") {
    options->autoencoder_linear_skip = FLAGS_baseline_linear_skip == "true";
  } else if (FLAGS_baseline_linear_skip != "decoder") {
    *error = "--baseline_linear_skip must be true, false or decoder, got '" +
             FLAGS_baseline_linear_skip + "'";
    return false;
  }
  if (FLAGS_baseline_hidden != "decoder") {
    std::vector<int> widths;
    const std::vector<std::string> items = SplitList(FLAGS_baseline_hidden);
    // An empty item is a typo (SplitList drops it), as --hidden says.
    if (!FLAGS_baseline_hidden.empty() &&
        static_cast<size_t>(std::count(FLAGS_baseline_hidden.begin(), FLAGS_baseline_hidden.end(),
                                       ',')) + 1 != items.size()) {
      *error = "--baseline_hidden has an empty width in '" + FLAGS_baseline_hidden + "'";
      return false;
    }
    for (const std::string& item : items) {
      int width = 0;
      if (!ParseInt(item, &width) || width < 1) {
        *error = "--baseline_hidden takes positive widths or 'decoder', got '" + item + "'";
        return false;
      }
      widths.push_back(width);
    }
    if (widths.empty()) {  // a linear auto-encoder is PCA about the neutral, already a row
      *error = "--baseline_hidden takes positive widths or 'decoder', got '" +
               FLAGS_baseline_hidden + "' (no hidden layer)";
      return false;
    }
    options->autoencoder_hidden_dims = widths;
  }
  options->training_pose_starts = FLAGS_held_out_starts;
  options->write_fields = FLAGS_write_fields;
  options->error_budget = FLAGS_error_budget;
  // The held-out poses' volumetric targets are made as prepare makes the training poses'
  // (the same spring stiffness, rule for inverted elements, tolerance and method).
  if (!VolumetricTargetOptionsFromFlags(&options->held_out_targets, error)) return false;
  if (FLAGS_report) {
    options->report_script = FLAGS_report_script.empty() ? DefaultReportScript() : FLAGS_report_script;
    if (options->report_script.empty()) {
      *error = "--report: the report script's default place is unknown (no /proc/self/exe); "
               "pass --report_script or --report=false";
      return false;
    }
    if (FLAGS_python.empty()) {
      *error = "--python must name a Python 3 interpreter (or pass --report=false)";
      return false;
    }
    options->python = FLAGS_python;
  }
  options->num_threads = FLAGS_threads;
  options->max_memory_bytes = MaxMemoryBytes();
  options->held_out_targets.num_threads = FLAGS_threads;
  return true;
}

FlagNames EvaluateFlagNames() {
  FlagNames flags = CommonFlagNames();
  const FlagNames fit = LatentFitFlagNames("fit.");
  flags.insert(flags.end(), fit.begin(), fit.end());
  const FlagNames targets = CommonFlagNames("held_out_targets.");
  flags.insert(flags.end(), targets.begin(), targets.end());
  flags.insert(flags.end(),
               {{"error_vertices", "--error_vertices"},
                {"autoencoder.latent_regularization", "--latent_regularization"},
                {"autoencoder.max_iterations", "--baseline_iterations"},
                {"autoencoder.max_restarts", "--train_restarts"},
                {"autoencoder_hidden_dims", "--baseline_hidden"},
                {"autoencoder_linear_skip", "--baseline_linear_skip"},
                {"autoencoder.lbfgs_scaling", "--baseline_lbfgs_scaling"},
                {"autoencoder.checkpoint_seconds", "--baseline_checkpoint_seconds"},
                {"held_out_targets.relative_stiffness", "--attachment_stiffness"},
                {"held_out_targets.inverted_targets", "--inverted_targets"},
                {"held_out_targets.solver.relative_force_tolerance", "--prepare_tolerance"}});
  return flags;
}

}  // namespace aqs
