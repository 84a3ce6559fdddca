// aqs_bench_solve: equilibrium solves from rest on large poses, with each method of
// QuasistaticSolver (--solver=newton: L-BFGS then Newton; lm: Levenberg-Marquardt then
// Newton), as counts and as seconds over one CHOLMOD factorization of the same mesh's
// stiffness measured in the same run.
//
// Cases:
//   lattice       a Kuhn-lattice bar (--lattice cubes, --spacing) fixed at x = 0 whose
//                 fibres contract above its middle and stretch below by --curl: it
//                 curls far from its rest shape;
//   model poses   with --model: each pose of --poses (training poses by name: the
//                 decoded latent of a trained model, else the pose's volumetric target;
//                 the bones at the pose's motion) and of --latents (NAME=latent file of
//                 aqs_fit, its bones), solved from the rest shape; with --springs,
//                 prepare's embedded simulation of each pose of --poses instead.
// Printed per case and method: converged, factorizations (all kinds), L-BFGS
// iterations, Newton steps (projected + exact), LM iterations, seconds and seconds in
// factorizations, and the largest vertex distance from the first method's result
// relative to the mesh's bounding-box diagonal.

#include <iostream>
#include <string>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/solve_benchmark.h"
#include "util/line_reader.h"

DEFINE_string(lattice, "40,4,4", "Cubes of the bar lattice along x, y, z (empty: no lattice case).");
DEFINE_double(spacing, 0.25, "Cube edge of the bar lattice.");
DEFINE_double(curl, 0.4, "Fibre contraction (above the middle) and stretch (below) of the bar.");
DEFINE_string(poses, "", "With --model: training poses to solve from rest (comma-separated).");
DEFINE_string(latents, "", "With --model: NAME=FILE pairs (comma-separated) of latent files to "
              "decode and solve from rest, the bones where the file's bone lines put them (at "
              "rest without).");
DEFINE_bool(springs, false, "With --poses: solve prepare's embedded simulation instead (the passive "
            "body, S = I, pulled by springs onto the pose's surface; see aqs_prepare).");
DEFINE_double(attachment_stiffness, 100.0, "With --springs: the springs' relative stiffness, in "
              "(0, 1e8] (as aqs_prepare's).");
DEFINE_string(methods, "newton,lm", "Solver methods to compare (the first is the reference).");
DEFINE_double(tolerance, 1e-6, "Relative force tolerance of the solves.");
DEFINE_int32(max_iterations, 1000, "Iterations at most per solve (factorizations or LM iterations).");
DEFINE_string(csv, "", "Optional CSV file for the figures.");
DECLARE_int32(threads);
DECLARE_string(model);

namespace aqs {
namespace {

int Main() {
  SolveBenchmarkOptions options;
  options.lattice.clear();
  for (const std::string& s : SplitList(FLAGS_lattice)) {
    int n = 0;
    if (!ParseInt(s, &n)) n = -1;  // not a whole number: refused as a cube count
    options.lattice.push_back(n);
  }
  options.spacing = FLAGS_spacing;
  options.curl = FLAGS_curl;
  options.model = FLAGS_model;
  options.poses = SplitList(FLAGS_poses);
  for (const std::string& item : SplitList(FLAGS_latents)) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos || eq == 0 || eq + 1 == item.size()) {
      PrintError("--latents takes NAME=FILE pairs ('" + item + "')");
      return 1;
    }
    options.latents.emplace_back(item.substr(0, eq), item.substr(eq + 1));
  }
  if (FLAGS_model.empty() && (!options.poses.empty() || !options.latents.empty())) {
    PrintError("--poses and --latents need --model");
    return 1;
  }
  // Flags that would be ignored: the methods are --methods; springs are the poses' own.
  std::string flag_error;
  if (!RefuseSolverMethodFlags(&flag_error)) {
    PrintError(flag_error);
    return 1;
  }
  if (options.poses.empty() &&
      (FLAGS_springs || !gflags::GetCommandLineFlagInfoOrDie("attachment_stiffness").is_default)) {
    PrintError("--springs and --attachment_stiffness describe solves of --poses: they need it");
    return 1;
  }
  options.springs = FLAGS_springs;
  options.attachment_stiffness = FLAGS_attachment_stiffness;
  options.methods = SplitList(FLAGS_methods);
  options.tolerance = FLAGS_tolerance;
  options.max_iterations = FLAGS_max_iterations;
  options.num_threads = FLAGS_threads;
  options.csv = FLAGS_csv;
  options.max_memory_bytes = MaxMemoryBytes();
  FlagNames flags = CommonFlagNames();
  flags.insert(flags.end(), {{"lattice, spacing", "--lattice, --spacing"},
                             {"lattice", "--lattice"},
                             {"curl", "--curl"},
                             {"poses", "--poses"},
                             {"latents", "--latents"},
                             {"attachment_stiffness", "--attachment_stiffness"},
                             {"methods", "--methods"},
                             {"tolerance", "--tolerance"},
                             {"max_iterations", "--max_iterations"},
                             {"csv", "--csv"}});
  std::string error;
  return FinishJob(RunSolveBenchmark(options, std::cout, &error), error, flags);
}

}  // namespace
}  // namespace aqs

int main(int argc, char** argv) {
  aqs::InitApp(
      "Equilibrium solves from rest on large poses, per solver method, in factorizations.\n"
      "  aqs_bench_solve [--lattice=40,4,4 --curl=0.4] [--model=DIR --poses=jawOpen "
      "--latents=mouthClose=Z.txt] [--methods=newton,lm] [--csv=F.csv]",
      &argc, &argv);
  return aqs::Main();
}
