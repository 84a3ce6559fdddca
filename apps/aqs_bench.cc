// aqs_bench: speed of the simulator on cube lattices, as ratios to one CHOLMOD
// factorization of the same mesh's rest stiffness measured in the same run.
//
// For each size: a Kuhn lattice of n^3 cubes (6 n^3 elements), the x = 0 face fixed,
// mu = 1, a smooth fibre actuation (physics/actuation_fields.h). Printed per size:
//   unit        one numeric CHOLMOD factorization of the rest stiffness (seconds);
//               the symbolic analysis is timed separately (done once per mesh)
//   lm_iter     one Levenberg-Marquardt iteration of the Ceres solve (minimizer time /
//               iterations of the solve from rest)
//   solve       the full solve from rest (iterations in parentheses)
//   warm        re-solve after a 1% change of the actuation from the previous solution
//   gradient    one adjoint gradient: assembly + factorization + solve + accumulation
//   peak_mem    peak resident memory of the process so far
//   svd         per element, the rotation-variant SVD of G_e = F_e S_e at the solved
//               state: ActiveQS's (Jacobi and QR, physics/rotation_variant_svd.h) and
//               Eigen's JacobiSVD (the reference), nanoseconds each, and their ratio
// Optionally one LM iteration with the other orderings of QuasistaticSolverOptions
// (ceres: Ceres' default static block AMD; c+post: with postordering; dynamic:
// dynamic_sparsity, CHOLMOD re-orders every iteration).

#include <iostream>
#include <string>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/lattice_benchmark.h"
#include "util/line_reader.h"

DEFINE_string(cubes, "12,20,35", "Lattice sizes: n cubes per side (6 n^3 elements each).");
DEFINE_double(amplitude, 0.15, "Peak strain of the synthetic actuation.");
DEFINE_double(tolerance, 1e-6, "Relative force tolerance of the solves.");
DECLARE_int32(threads);
DEFINE_int32(compare_orderings_max_elements, 60000,
             "Also time one LM iteration with the other orderings of the normal equations "
             "(Ceres' default static ordering, with and without postordering, and dynamic "
             "sparsity) for sizes up to this many elements (0: never).");
DEFINE_string(csv, "", "Optional CSV file for the figures.");

int main(int argc, char** argv) {
  aqs::InitApp("Benchmark the simulator on cube lattices.\n  aqs_bench [--cubes=12,20,35]",
               &argc, &argv);
  aqs::LatticeBenchmarkOptions options;
  std::string error;
  if (!aqs::RefuseSolverMethodFlags(&error)) {
    aqs::PrintError(error);
    return 1;
  }
  options.cubes.clear();
  for (const std::string& item : aqs::SplitList(FLAGS_cubes)) {
    int n = 0;
    if (!aqs::ParseInt(item, &n) || n < 1) {
      aqs::PrintError("--cubes takes positive integers, got '" + item + "'");
      return 1;
    }
    options.cubes.push_back(n);
  }
  options.amplitude = FLAGS_amplitude;
  options.tolerance = FLAGS_tolerance;
  options.num_threads = FLAGS_threads;
  options.compare_orderings_max_elements = FLAGS_compare_orderings_max_elements;
  options.csv = FLAGS_csv;
  options.max_memory_bytes = aqs::MaxMemoryBytes();
  aqs::FlagNames flags = aqs::CommonFlagNames();
  flags.insert(flags.end(), {{"cubes", "--cubes"},
                             {"amplitude", "--amplitude"},
                             {"tolerance", "--tolerance"},
                             {"compare_orderings_max_elements", "--compare_orderings_max_elements"},
                             {"csv", "--csv"}});
  return aqs::FinishJob(aqs::RunLatticeBenchmark(options, std::cout, &error), error, flags);
}
