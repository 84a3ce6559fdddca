#ifndef AQS_JOBS_SOLVE_BENCHMARK_H_
#define AQS_JOBS_SOLVE_BENCHMARK_H_

#include <ostream>
#include <string>
#include <utility>
#include <vector>

#include "util/job_status.h"
#include "util/memory_limit.h"

namespace aqs {

// What aqs_bench_solve does: equilibrium solves from rest on large poses, with each
// method of QuasistaticSolver (newton: L-BFGS then Newton; lm: Levenberg-Marquardt then
// Newton), as counts and as seconds over one CHOLMOD factorization of the same mesh's
// stiffness at rest measured in the same run (the median of three). Cases:
//   lattice       a Kuhn-lattice bar of `lattice` cubes (x, y, z) and `spacing`, fixed at
//                 x = 0, whose fibres (x) contract by `curl` above its middle and stretch
//                 by it below: it curls far from its rest shape;
//   model poses   with `model`: each training pose of `poses` (the decoded latent of a
//                 trained model, else the pose's volumetric target; the bones at the
//                 pose's motion) and each (name, latent file) of `latents` (its bones),
//                 solved from the rest shape; with `springs`, prepare's embedded
//                 simulation of each pose of `poses` instead (the passive body pulled onto
//                 the pose's surface, springs of `attachment_stiffness`).
struct SolveBenchmarkOptions {
  std::vector<int> lattice = {40, 4, 4};  // empty: no lattice case
  double spacing = 0.25;
  double curl = 0.4;  // in [0, 1)
  std::string model;  // empty: no model cases
  std::vector<std::string> poses;
  std::vector<std::pair<std::string, std::string>> latents;  // (name, latent file)
  bool springs = false;
  double attachment_stiffness = 100.0;
  std::vector<std::string> methods = {"newton", "lm"};  // the first is the reference
  double tolerance = 1e-6;  // relative force tolerance of the solves
  int max_iterations = 1000;
  int num_threads = 2;
  std::string csv;  // optional: the figures as CSV (written atomically)
  // The lattice's solves (EquilibriumSolverMemoryBytes) must fit.
  double max_memory_bytes = kDefaultMaxMemoryBytes;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// Runs the benchmark: reads and checks every input (the model, its poses, the latent
// files, the CSV's folder) first, then solves each case with each method and prints a
// row per solve to `out`: converged, factorizations (all kinds), L-BFGS iterations,
// Newton steps (projected + exact), LM iterations, seconds and seconds over the unit,
// and the largest vertex distance from the first method's result over the mesh's
// bounding-box diagonal. Status kBadInput with *error for bad options or inputs, or a
// CSV that cannot be written.
JobStatus RunSolveBenchmark(const SolveBenchmarkOptions& options, std::ostream& out,
                            std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_SOLVE_BENCHMARK_H_
