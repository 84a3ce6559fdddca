#ifndef AQS_JOBS_LATTICE_BENCHMARK_H_
#define AQS_JOBS_LATTICE_BENCHMARK_H_

#include <ostream>
#include <string>
#include <vector>

#include "util/job_status.h"
#include "util/memory_limit.h"

namespace aqs {

// What aqs_bench does: the speed of the simulator on cube lattices, as ratios to one
// CHOLMOD factorization of the same mesh's rest stiffness measured in the same run. For
// each size n of `cubes`: a Kuhn lattice of n^3 cubes (6 n^3 elements) of edge 1/n, the
// x = 0 face fixed, mu = 1, a smooth fibre actuation of peak strain `amplitude`
// (physics/actuation_fields.h).
struct LatticeBenchmarkOptions {
  std::vector<int> cubes = {12, 20, 35};
  double amplitude = 0.15;
  double tolerance = 1e-6;  // relative force tolerance of the solves
  int num_threads = 2;
  // One LM iteration with the other orderings of the normal equations for meshes of at
  // most this many elements.
  int compare_orderings_max_elements = 60000;
  std::string csv;  // optional: the figures as CSV (written atomically)
  // Every size's solves (EquilibriumSolverMemoryBytes) must fit.
  double max_memory_bytes = kDefaultMaxMemoryBytes;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// The figures of one size (seconds unless named).
struct LatticeBenchmarkRow {
  int cubes = 0;
  int elements = 0;
  int dofs = 0;
  double factor_nonzeros = 0;
  std::string ordering;
  double analysis = 0;
  double unit = 0;
  double lm_iteration = 0;
  double lm_evaluation = 0, lm_linear_solver = 0;
  double lm_solve = 0, lm_warm = 0;      // Levenberg-Marquardt only
  int lm_solve_iterations = 0, lm_warm_iterations = 0;
  double solve = 0, warm = 0;            // hybrid (default)
  // Default method: L-BFGS iterations and factorizations (all kinds).
  int solve_lm = 0, solve_newton = 0, warm_lm = 0, warm_newton = 0;
  double gradient = 0;
  double gradient_assembly = 0, gradient_factorization = 0, gradient_solve = 0,
         gradient_accumulation = 0;
  double static_lm_iteration = 0;             // 0: not measured
  double static_postordered_lm_iteration = 0;  // 0: not measured
  double dynamic_lm_iteration = 0;             // 0: not measured
  double peak_gb = 0;
  double svd_ns = 0, svd_reference_ns = 0;  // per element, at the solved state
};

// Measures lattice size n (RunLatticeBenchmark's per-size work): the unit (one numeric
// factorization of the rest stiffness, best of 2; the symbolic analysis apart), one
// Levenberg-Marquardt iteration and its parts, solves from rest and warm re-solves after
// a 1% change of the actuation (LM only, and the default method), one adjoint gradient
// and its parts, the element SVDs (ActiveQS's and Eigen's JacobiSVD, ns per element), the
// other orderings (up to compare_orderings_max_elements) and the peak memory so far.
// Warnings (a solve that did not converge) go to `out`. False with *error if the rest
// stiffness does not factorize or the gradient is not finite.
bool MeasureLattice(const LatticeBenchmarkOptions& options, int n, std::ostream& out,
                    LatticeBenchmarkRow* row, std::string* error);

// Runs the benchmark: checks every size first, then measures each and prints a row of
// ratios to its unit (and a line of parts) to `out`, then writes the CSV. Status
// kBadInput with *error for bad options or a CSV that cannot be written, kNotConverged if
// a measurement fails.
JobStatus RunLatticeBenchmark(const LatticeBenchmarkOptions& options, std::ostream& out,
                              std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_LATTICE_BENCHMARK_H_
