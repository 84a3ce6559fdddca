// aqs_fit: fit a trained model's latent (and bone motions) to a new pose, markers or a
// scan, and write the fitted surface (the neutral's vertex order and faces).
// Exit status: 0 done; 1 bad input; 2 the fit could not simulate its target.

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/evaluate_job.h"
#include "jobs/fit_job.h"

DECLARE_string(model);
DEFINE_string(target, "", "The target: a pose surface (OBJ, the neutral's vertex order), a "
              "markers file ('vertex x y z' lines, .txt) or a point cloud (OBJ or PLY).");
DEFINE_string(target_kind, "auto", "pose, markers, points or auto (by extension and vertex count).");
DEFINE_string(output, "", "The fitted surface (OBJ).");
DEFINE_string(output_volume, "", "Optional: the fitted equilibrium (.vtu for ParaView, or .mesh).");
DEFINE_string(latent_output, "", "Optional: the fitted latent (and bones) as a latent file.");
DEFINE_string(initial_latent, "", "Optional: start from this latent file (default: the mean "
              "training latent, bones at rest).");
DEFINE_bool(fit_bones, true, "Also fit the model's bone motions (e.g. the jaw).");
DEFINE_double(fit_regularization, 1e-3, "Weight of the latent prior |z|^2.");
DEFINE_int32(fit_iterations, 50, "Levenberg-Marquardt iterations (per matching round for points).");
DEFINE_double(max_distance, 1.0, "Points: ignore scan points farther than this from the surface.");
DEFINE_double(robust_scale, 0.2, "Points: Cauchy scale of the robust weights (0: none).");
DEFINE_int32(rounds, 8, "Points: matching rounds.");
DEFINE_double(fit_tolerance, 1e-6, "Relative force tolerance of the equilibria.");
DEFINE_string(compare_to, "", "Optional: a ground-truth surface (OBJ, the neutral's vertex order) "
              "to measure the fitted surface against (e.g. the pose a scan was taken of).");
DEFINE_string(compare_vertices, "", "Vertices of that comparison, e.g. 0:9409 (default: all).");
DECLARE_int32(threads);

int main(int argc, char** argv) {
  aqs::InitApp("Fit a trained model to a pose, markers or a scan.\n"
               "  aqs_fit --model=MODEL --target=T --output=OUT.obj [--latent_output=Z.txt]",
               &argc, &argv);
  aqs::FitJobOptions options;
  options.model = FLAGS_model;
  options.target = FLAGS_target;
  options.target_kind = FLAGS_target_kind;
  options.output = FLAGS_output;
  options.output_volume = FLAGS_output_volume;
  options.latent_output = FLAGS_latent_output;
  options.initial_latent = FLAGS_initial_latent;
  options.compare_to = FLAGS_compare_to;
  std::string error;
  if (!FLAGS_compare_vertices.empty() &&
      !aqs::ParseVertexRanges(FLAGS_compare_vertices, &options.compare_vertices, &error)) {
    aqs::PrintError(error);
    return 1;
  }
  options.fit.fit_bones = FLAGS_fit_bones;
  options.fit.latent_regularization = FLAGS_fit_regularization;
  options.fit.max_iterations = FLAGS_fit_iterations;
  options.fit.solver.relative_force_tolerance = FLAGS_fit_tolerance;
  if (!aqs::SolverMethodFromFlag(&options.fit.solver, &error)) {
    aqs::PrintError(error);
    return 1;
  }
  options.fit.num_threads = FLAGS_threads;
  options.points.max_distance = FLAGS_max_distance;
  options.points.robust_scale = FLAGS_robust_scale;
  options.points.max_rounds = FLAGS_rounds;
  options.points.iterations_per_round = std::min(FLAGS_fit_iterations, 6);
  const aqs::FitJobResult result = aqs::RunFitJob(options, std::cout);
  if (result.status != aqs::JobStatus::kOk) aqs::PrintError(result.message);
  return result.status == aqs::JobStatus::kOk ? 0 : (result.status == aqs::JobStatus::kBadInput ? 1 : 2);
}
