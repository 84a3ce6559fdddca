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

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include <gflags/gflags.h>

#include "app_common.h"
#include "diff/equilibrium_differentiator.h"
#include "physics/stiffness_assembly.h"
#include "sparse/sparse_cholesky.h"
#include "sparse/stiffness_pattern.h"
#include "equilibrium/quasistatic_solver.h"
#include "mesh/lattice.h"
#include "physics/actuation_fields.h"
#include "physics/rotation_variant_svd.h"
#include "prepare/volumetric_targets.h"
#include "util/atomic_file.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/memory_limit.h"
#include "util/blas.h"
#include "util/process_memory.h"
#include "util/wall_timer.h"

DEFINE_string(cubes, "12,20,35", "Lattice sizes: n cubes per side (6 n^3 elements each).");
DEFINE_double(amplitude, 0.15, "Peak strain of the synthetic actuation.");
DEFINE_double(tolerance, 1e-6, "Relative force tolerance of the solves.");
DECLARE_int32(threads);
DEFINE_int32(compare_orderings_max_elements, 60000,
             "Also time one LM iteration with the other orderings of the normal equations "
             "(Ceres' default static ordering, with and without postordering, and dynamic "
             "sparsity) for sizes up to this many elements (0: never).");
DEFINE_string(csv, "", "Optional CSV file for the figures.");

namespace aqs {
namespace {

struct Row {
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

// Nanoseconds per element of `svd` over every element's G_e = F_e S_e at (x, a), best of 3.
template <typename Svd>
double SvdNanoseconds(const ShapeTargetModel& model, const Eigen::Matrix3Xd& x,
                      const ActuationMatrix& a, Svd svd) {
  std::vector<Eigen::Matrix3d> g(model.num_elements());
  for (int e = 0; e < model.num_elements(); ++e) {
    g[e] = model.DeformationGradient(x, e) * SymmetricFromActuation(a.col(e).data());
  }
  double best = 1e30, sink = 0.0;
  for (int repeat = 0; repeat < 3; ++repeat) {
    WallTimer timer;
    for (const Eigen::Matrix3d& m : g) sink += svd(m).sigma[0];
    best = std::min(best, timer.Seconds());
  }
  if (!std::isfinite(sink)) std::printf("  warning: a non-finite singular value\n");
  return 1e9 * best / std::max(1, model.num_elements());
}

// Seconds of one LM iteration from rest with the given ordering of the normal equations.
double OneIterationSeconds(const ShapeTargetModel& model, const BoundaryConditions& bc,
                           const ActuationMatrix& a, NormalEquationsOrdering ordering,
                           bool postordering) {
  QuasistaticSolverOptions options;
  options.method = EquilibriumMethod::kLevenbergMarquardt;
  options.ordering = ordering;
  options.use_postordering = postordering;
  options.max_iterations = 2;
  options.num_threads = FLAGS_threads;
  options.relative_force_tolerance = FLAGS_tolerance;
  QuasistaticSolver solver(model, bc, options);
  solver.actuation() = a;
  const QuasistaticSolveReport report = solver.Solve();
  return report.ceres_minimizer_seconds / std::max(1, report.iterations);
}

Row Measure(int n) {
  Row row;
  row.cubes = n;
  LatticeOptions lattice;
  lattice.nx = lattice.ny = lattice.nz = n;
  lattice.spacing = 1.0 / n;
  const TetMesh mesh = MakeLatticeMesh(lattice);
  BoundaryConditions bc;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) < 1e-12) bc.vertices.push_back(v);
  }
  const ShapeTargetModel model(mesh, 1.0);
  const ActuationMatrix actuation = SmoothFibreActuation(mesh, FLAGS_amplitude);
  row.elements = mesh.num_tets();

  // The unit: one numeric factorization of the rest stiffness.
  const std::vector<bool> fixed = FixedVertexMask(bc, mesh.num_vertices());
  {
    const StiffnessPattern pattern(mesh.tets, fixed);
    row.dofs = pattern.num_dofs();
    std::vector<double> rest_values;
    AssembleStiffness(model, pattern, mesh.vertices, IdentityActuations(mesh.num_tets()),
                      StiffnessKind::kExact, FLAGS_threads, &rest_values);
    SparseCholesky cholesky(pattern.num_dofs(), &pattern.column_starts(), &pattern.row_indices());
    cholesky.Analyze();
    row.analysis = cholesky.analyze_seconds();
    row.factor_nonzeros = cholesky.factor_nonzeros();
    row.ordering = cholesky.ordering_name();
    std::string error;
    double best = 1e30;
    for (int repeat = 0; repeat < 2; ++repeat) {
      if (!cholesky.Factorize(rest_values, &error)) {
        PrintError("rest stiffness factorization failed: " + error);
        std::exit(1);
      }
      best = std::min(best, cholesky.factorize_seconds());
    }
    row.unit = best;
  }
  const ActuationMatrix identity = IdentityActuations(mesh.num_tets());
  const ActuationMatrix changed = identity + 1.01 * (actuation - identity);

  // Solve from rest, then warm re-solve after a 1% change: Levenberg-Marquardt only,
  // then the default method (L-BFGS far from equilibrium, Newton near it).
  for (const bool newton : {false, true}) {
    QuasistaticSolverOptions options;
    options.relative_force_tolerance = FLAGS_tolerance;
    options.num_threads = FLAGS_threads;
    if (!newton) {
      options.method = EquilibriumMethod::kLevenbergMarquardt;
      options.newton_relative_force = 0.0;
    }
    QuasistaticSolver solver(model, bc, options);
    solver.actuation() = actuation;
    const QuasistaticSolveReport cold = solver.Solve();
    if (!cold.converged) std::printf("  warning: %s\n", cold.Summary().c_str());
    solver.actuation() = changed;
    const QuasistaticSolveReport warm = solver.Solve();
    if (!warm.converged) std::printf("  warning: %s\n", warm.Summary().c_str());
    if (!newton) {
      row.lm_iteration = cold.ceres_minimizer_seconds / std::max(1, cold.lm_iterations);
      row.lm_evaluation = cold.ceres_evaluation_seconds / std::max(1, cold.lm_iterations);
      row.lm_linear_solver = cold.ceres_linear_solver_seconds / std::max(1, cold.lm_iterations);
      row.lm_solve = cold.seconds;
      row.lm_solve_iterations = cold.iterations;
      row.lm_warm = warm.seconds;
      row.lm_warm_iterations = warm.iterations;
      continue;
    }
    row.solve = cold.seconds;
    row.solve_lm = cold.lbfgs_iterations;
    row.solve_newton = cold.factorizations;
    row.warm = warm.seconds;
    row.warm_lm = warm.lbfgs_iterations;
    row.warm_newton = warm.factorizations;

    // One adjoint gradient of L = 1/2 |x - X|^2 at the solution, sharing the solver's
    // stiffness factorization (its symbolic analysis is already done).
    const Eigen::Matrix3Xd x = solver.positions();
    row.svd_ns = SvdNanoseconds(model, x, solver.actuation(), ComputeRotationVariantSvd);
    row.svd_reference_ns =
        SvdNanoseconds(model, x, solver.actuation(), RotationVariantSvdReference);
    EquilibriumDifferentiator differentiator(solver.stiffness_factorization(),
                                             EquilibriumDifferentiatorOptions{FLAGS_threads});
    WallTimer timer;
    std::string error;
    if (!differentiator.Prepare(x, solver.actuation(), &error)) {
      PrintError(error);
      std::exit(1);
    }
    const DifferentiationTimings prepare = differentiator.timings();
    const ActuationMatrix gradient = differentiator.LossGradient(x - mesh.vertices);
    row.gradient = timer.Seconds() - prepare.analysis;  // analysis: once per mesh
    row.gradient_assembly = prepare.assembly;
    row.gradient_factorization = prepare.factorization;
    row.gradient_solve = differentiator.timings().solve;
    row.gradient_accumulation = differentiator.timings().accumulation;
    if (!gradient.allFinite()) {
      PrintError("non-finite gradient");
      std::exit(1);
    }
  }

  if (row.elements <= FLAGS_compare_orderings_max_elements) {
    row.static_lm_iteration =
        OneIterationSeconds(model, bc, actuation, NormalEquationsOrdering::kCeresDefault, false);
    row.static_postordered_lm_iteration =
        OneIterationSeconds(model, bc, actuation, NormalEquationsOrdering::kCeresDefault, true);
    row.dynamic_lm_iteration =
        OneIterationSeconds(model, bc, actuation, NormalEquationsOrdering::kDynamic, false);
  }
  row.peak_gb = PeakResidentBytes() / 1e9;
  return row;
}

}  // namespace
}  // namespace aqs

int main(int argc, char** argv) {
  aqs::InitApp("Benchmark the simulator on cube lattices.\n  aqs_bench [--cubes=12,20,35]",
               &argc, &argv);
  std::vector<aqs::Row> rows;
  // Every size is checked before the first is measured.
  std::vector<int> sizes;
  std::string error;
  if (!FLAGS_csv.empty() && !aqs::CheckOutputFile(FLAGS_csv, &error)) {
    aqs::PrintError("--csv: " + error);
    return 1;
  }
  if (!std::isfinite(FLAGS_amplitude) || !(FLAGS_tolerance > 0) ||
      !std::isfinite(FLAGS_tolerance)) {
    aqs::PrintError("--amplitude must be finite and --tolerance finite and > 0");
    return 1;
  }
  for (const std::string& item : aqs::SplitList(FLAGS_cubes)) {
    int n = 0;
    if (!aqs::ParseInt(item, &n) || n < 1) {
      aqs::PrintError("--cubes takes positive integers, got '" + item + "'");
      return 1;
    }
    aqs::LatticeOptions lattice;
    lattice.nx = lattice.ny = lattice.nz = n;
    lattice.spacing = 1.0 / n;
    const double elements = 6.0 * n * n * n;
    if (!lattice.Validate(&error)) {
      aqs::PrintError("--cubes: " + error);
      return 1;
    }
    if (aqs::EquilibriumSolverMemoryBytes(elements) > aqs::MaxMemoryBytes()) {
      aqs::PrintError("--cubes: " + aqs::FormatBytes(aqs::EquilibriumSolverMemoryBytes(elements)) +
                      " estimated for the solves of " +
                      std::to_string(static_cast<long long>(elements)) +
                      " elements, above --max_memory_gb");
      return 1;
    }
    sizes.push_back(n);
  }
  std::printf("%8s %8s %9s %7s | %7s %12s %12s | %12s %12s %8s | %7s %7s %7s | %7s\n",
              "elements", "dofs", "L_nnz", "unit_s", "lm_iter", "LM:solve(it)", "LM:warm(it)",
              "solve(lb+f)", "warm(lb+f)", "gradient", "ceres", "c+post", "dynamic",
              "peak_GB");
  for (const int n : sizes) {
    const aqs::Row r = aqs::Measure(n);
    rows.push_back(r);
    auto ratio = [&r](double seconds) {
      char text[32] = "-";
      if (seconds > 0) std::snprintf(text, sizeof(text), "%.2f", seconds / r.unit);
      return std::string(text);
    };
    char lm_solve[32], lm_warm[32], solve[32], warm[32];
    std::snprintf(lm_solve, sizeof(lm_solve), "%.2f(%d)", r.lm_solve / r.unit,
                  r.lm_solve_iterations);
    std::snprintf(lm_warm, sizeof(lm_warm), "%.2f(%d)", r.lm_warm / r.unit, r.lm_warm_iterations);
    std::snprintf(solve, sizeof(solve), "%.2f(%d+%d)", r.solve / r.unit, r.solve_lm,
                  r.solve_newton);
    std::snprintf(warm, sizeof(warm), "%.2f(%d+%d)", r.warm / r.unit, r.warm_lm, r.warm_newton);
    std::printf("%8d %8d %9.3g %7.3f | %7.2f %12s %12s | %12s %12s %8.2f | %7s %7s %7s | %7.2f\n",
                r.elements, r.dofs, r.factor_nonzeros, r.unit, r.lm_iteration / r.unit, lm_solve,
                lm_warm, solve, warm, r.gradient / r.unit,
                ratio(r.static_lm_iteration).c_str(),
                ratio(r.static_postordered_lm_iteration).c_str(),
                ratio(r.dynamic_lm_iteration).c_str(), r.peak_gb);
    std::printf("         analysis %.3f s (%s, once per mesh); lm_iter = evaluation %.2f + linear "
                "solver %.2f + other %.2f; gradient = assembly %.2f + factorization %.2f + solve "
                "%.2f + accumulation %.2f\n"
                "         svd per element at the solution: %.0f ns, Eigen's JacobiSVD %.0f ns "
                "(%.2fx)\n",
                r.analysis, r.ordering.c_str(), r.lm_evaluation / r.unit,
                r.lm_linear_solver / r.unit,
                (r.lm_iteration - r.lm_evaluation - r.lm_linear_solver) / r.unit,
                r.gradient_assembly / r.unit, r.gradient_factorization / r.unit,
                r.gradient_solve / r.unit, r.gradient_accumulation / r.unit, r.svd_ns,
                r.svd_reference_ns, r.svd_reference_ns / r.svd_ns);
    std::fflush(stdout);
  }
  std::printf("Ratios are to 'unit', one CHOLMOD numeric factorization of the same rest stiffness "
              "(best of 2), measured in this run.\nLM: Levenberg-Marquardt (Ceres) only; "
              "solve/warm: the default method, (L-BFGS iterations + factorizations).\n%s\n",
              aqs::BlasDescription().c_str());
  if (!FLAGS_csv.empty()) {
    std::string csv =
        "elements,dofs,factor_nonzeros,ordering,analysis_s,unit_s,lm_iteration_s,lm_solve_s,"
        "lm_solve_iterations,lm_warm_s,lm_warm_iterations,solve_s,solve_lbfgs_iterations,"
        "solve_factorizations,warm_s,warm_lbfgs_iterations,warm_factorizations,gradient_s,"
        "gradient_assembly_s,"
        "gradient_factorization_s,gradient_solve_s,gradient_accumulation_s,"
        "ceres_default_lm_iteration_s,ceres_default_postordered_lm_iteration_s,"
        "dynamic_lm_iteration_s,peak_gb,svd_ns,svd_reference_ns\n";
    for (const aqs::Row& r : rows) {
      char line[1024];
      std::snprintf(line, sizeof(line),
                    "%d,%d,%.6g,%s,%.6g,%.6g,%.6g,%.6g,%d,%.6g,%d,%.6g,%d,%d,%.6g,%d,%d,%.6g,%.6g,"
                    "%.6g,%.6g,%.6g,%.6g,"
                    "%.6g,%.6g,%.6g,%.6g,%.6g\n",
                    r.elements, r.dofs, r.factor_nonzeros, r.ordering.c_str(), r.analysis, r.unit,
                    r.lm_iteration, r.lm_solve, r.lm_solve_iterations, r.lm_warm,
                    r.lm_warm_iterations, r.solve, r.solve_lm, r.solve_newton, r.warm, r.warm_lm,
                    r.warm_newton, r.gradient, r.gradient_assembly, r.gradient_factorization, r.gradient_solve,
                    r.gradient_accumulation, r.static_lm_iteration,
                    r.static_postordered_lm_iteration, r.dynamic_lm_iteration, r.peak_gb,
                    r.svd_ns, r.svd_reference_ns);
      csv += line;
    }
    std::string error;
    if (!aqs::WriteFileAtomically(FLAGS_csv, csv, &error)) {
      aqs::PrintError(error);
      return 1;
    }
  }
  return 0;
}
