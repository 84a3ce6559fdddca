#include "jobs/lattice_benchmark.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "diff/equilibrium_differentiator.h"
#include "equilibrium/quasistatic_solver.h"
#include "mesh/lattice.h"
#include "physics/actuation_fields.h"
#include "physics/rotation_variant_svd.h"
#include "physics/stiffness_assembly.h"
#include "prepare/volumetric_targets.h"
#include "sparse/sparse_cholesky.h"
#include "sparse/stiffness_pattern.h"
#include "util/atomic_file.h"
#include "util/blas.h"
#include "util/input_file.h"
#include "util/option_checks.h"
#include "util/process_memory.h"
#include "util/machine_info.h"
#include "util/string_format.h"
#include "util/wall_timer.h"

namespace aqs {

bool LatticeBenchmarkOptions::Validate(std::string* error) const {
  OptionChecks checks;
  checks.Require(!cubes.empty(), "cubes must list a lattice size")
      // The fibres' stretches 1 - amplitude sin(.) etc. stay positive (SmoothFibreActuation).
      .Require(std::abs(amplitude) < 1.0,
               "amplitude must be in (-1, 1) (is " + OptionValue(amplitude) +
                   "): beyond, some fibres' target stretch is not positive")
      .Positive("tolerance", tolerance)
      .ReachableTolerance("tolerance", tolerance)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .IntAtLeast("compare_orderings_max_elements", compare_orderings_max_elements, 0)
      .Positive("max_memory_bytes", max_memory_bytes);
  if (!checks.Done(error)) return false;
  // Every size before the first is measured.
  for (int n : cubes) {
    if (n < 1) {
      *error = "cubes takes positive integers, got " + std::to_string(n);
      return false;
    }
    LatticeOptions lattice;
    lattice.nx = lattice.ny = lattice.nz = n;
    lattice.spacing = 1.0 / n;
    if (!lattice.Validate(error)) {
      *error = "cubes: " + *error;
      return false;
    }
    const double elements = 6.0 * n * n * n;
    if (!CheckMemoryEstimate(EquilibriumSolverMemoryBytes(elements), max_memory_bytes,
                             "the solves of " + std::to_string(n) + "^3 cubes",
                             std::to_string(static_cast<long long>(elements)) + " elements",
                             error)) {
      return false;
    }
  }
  return true;
}

namespace {

// Nanoseconds per element of `svd` over every element's G_e = F_e S_e at (x, a), best of 3.
template <typename Svd>
double SvdNanoseconds(const ShapeTargetModel& model, const Eigen::Matrix3Xd& x,
                      const ActuationMatrix& a, Svd svd, std::ostream& out) {
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
  if (!std::isfinite(sink)) out << "  warning: a non-finite singular value\n";
  return 1e9 * best / std::max(1, model.num_elements());
}

// Seconds of one LM iteration from rest with the given ordering of the normal equations.
double OneIterationSeconds(const LatticeBenchmarkOptions& benchmark, const ShapeTargetModel& model,
                           const BoundaryConditions& bc, const ActuationMatrix& a,
                           NormalEquationsOrdering ordering, bool postordering) {
  QuasistaticSolverOptions options;
  options.method = EquilibriumMethod::kLevenbergMarquardt;
  options.ordering = ordering;
  options.use_postordering = postordering;
  options.max_iterations = 2;
  options.num_threads = benchmark.num_threads;
  options.relative_force_tolerance = benchmark.tolerance;
  QuasistaticSolver solver(model, bc, options);
  solver.actuation() = a;
  const QuasistaticSolveReport report = solver.Solve();
  return report.ceres_minimizer_seconds / std::max(1, report.iterations);
}

}  // namespace

bool MeasureLattice(const LatticeBenchmarkOptions& benchmark, int n, std::ostream& out,
                    LatticeBenchmarkRow* result, std::string* error) {
  LatticeBenchmarkRow& row = *result;
  row = LatticeBenchmarkRow();
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
  const ActuationMatrix actuation = SmoothFibreActuation(mesh, benchmark.amplitude);
  row.elements = mesh.num_tets();

  // The unit: one numeric factorization of the rest stiffness.
  const std::vector<bool> fixed = FixedVertexMask(bc, mesh.num_vertices());
  {
    const StiffnessPattern pattern(mesh.tets, fixed);
    row.dofs = pattern.num_dofs();
    std::vector<double> rest_values;
    AssembleStiffness(model, pattern, mesh.vertices, IdentityActuations(mesh.num_tets()),
                      StiffnessKind::kExact, benchmark.num_threads, &rest_values);
    SparseCholesky cholesky(pattern.num_dofs(), &pattern.column_starts(), &pattern.row_indices());
    cholesky.Analyze();
    row.analysis = cholesky.analyze_seconds();
    row.factor_nonzeros = cholesky.factor_nonzeros();
    row.ordering = cholesky.ordering_name();
    double best = 1e30;
    for (int repeat = 0; repeat < 2; ++repeat) {
      if (!cholesky.Factorize(rest_values, error)) {
        *error = "the rest stiffness of " + std::to_string(n) + "^3 cubes: " + *error;
        return false;
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
    options.relative_force_tolerance = benchmark.tolerance;
    options.num_threads = benchmark.num_threads;
    if (!newton) {
      options.method = EquilibriumMethod::kLevenbergMarquardt;
      options.newton_relative_force = 0.0;
    }
    QuasistaticSolver solver(model, bc, options);
    solver.actuation() = actuation;
    const QuasistaticSolveReport cold = solver.Solve();
    if (!cold.converged) out << "  warning: " << cold.Summary() << "\n";
    solver.actuation() = changed;
    const QuasistaticSolveReport warm = solver.Solve();
    if (!warm.converged) out << "  warning: " << warm.Summary() << "\n";
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
    row.svd_ns = SvdNanoseconds(
        model, x, solver.actuation(),
        [](const Eigen::Matrix3d& g) { return ComputeRotationVariantSvd(g); }, out);
    row.svd_reference_ns =
        SvdNanoseconds(model, x, solver.actuation(), RotationVariantSvdReference, out);
    EquilibriumDifferentiator differentiator(
        solver.stiffness_factorization(), EquilibriumDifferentiatorOptions{benchmark.num_threads});
    WallTimer timer;
    if (!differentiator.Prepare(x, solver.actuation(), error)) return false;
    const DifferentiationTimings prepare = differentiator.timings();
    const ActuationMatrix gradient = differentiator.LossGradient(x - mesh.vertices);
    row.gradient = timer.Seconds() - prepare.analysis;  // analysis: once per mesh
    row.gradient_assembly = prepare.assembly;
    row.gradient_factorization = prepare.factorization;
    row.gradient_solve = differentiator.timings().solve;
    row.gradient_accumulation = differentiator.timings().accumulation;
    if (!gradient.allFinite()) {
      *error = "the gradient on " + std::to_string(n) + "^3 cubes is not finite";
      return false;
    }
  }

  if (row.elements <= benchmark.compare_orderings_max_elements) {
    row.static_lm_iteration = OneIterationSeconds(benchmark, model, bc, actuation,
                                                  NormalEquationsOrdering::kCeresDefault, false);
    row.static_postordered_lm_iteration = OneIterationSeconds(
        benchmark, model, bc, actuation, NormalEquationsOrdering::kCeresDefault, true);
    row.dynamic_lm_iteration = OneIterationSeconds(benchmark, model, bc, actuation,
                                                   NormalEquationsOrdering::kDynamic, false);
  }
  row.peak_gb = PeakResidentBytes() / 1e9;
  return true;
}

JobStatus RunLatticeBenchmark(const LatticeBenchmarkOptions& options, std::ostream& out,
                              std::string* error) {
  if (!options.Validate(error)) return JobStatus::kBadInput;
  if (!options.csv.empty() && !CheckOutputFile(options.csv, error)) {
    *error = "csv: " + *error;
    return JobStatus::kBadInput;
  }
  out << BenchmarkMachineLine() << "\n";
  out << StringPrintf("%8s %8s %9s %7s | %7s %12s %12s | %12s %12s %8s | %7s %7s %7s | %7s\n",
                      "elements", "dofs", "L_nnz", "unit_s", "lm_iter", "LM:solve(it)",
                      "LM:warm(it)", "solve(lb+f)", "warm(lb+f)", "gradient", "ceres", "c+post",
                      "dynamic", "peak_GB");
  std::vector<LatticeBenchmarkRow> rows;
  for (const int n : options.cubes) {
    LatticeBenchmarkRow r;
    if (!MeasureLattice(options, n, out, &r, error)) return JobStatus::kNotConverged;
    rows.push_back(r);
    auto ratio = [&r](double seconds) {
      return seconds > 0 ? StringPrintf("%.2f", seconds / r.unit) : std::string("-");
    };
    const std::string lm_solve =
        StringPrintf("%.2f(%d)", r.lm_solve / r.unit, r.lm_solve_iterations);
    const std::string lm_warm = StringPrintf("%.2f(%d)", r.lm_warm / r.unit, r.lm_warm_iterations);
    const std::string solve =
        StringPrintf("%.2f(%d+%d)", r.solve / r.unit, r.solve_lm, r.solve_newton);
    const std::string warm = StringPrintf("%.2f(%d+%d)", r.warm / r.unit, r.warm_lm, r.warm_newton);
    out << StringPrintf(
        "%8d %8d %9.3g %7.3f | %7.2f %12s %12s | %12s %12s %8.2f | %7s %7s %7s | %7.2f\n",
        r.elements, r.dofs, r.factor_nonzeros, r.unit, r.lm_iteration / r.unit, lm_solve.c_str(),
        lm_warm.c_str(), solve.c_str(), warm.c_str(), r.gradient / r.unit,
        ratio(r.static_lm_iteration).c_str(), ratio(r.static_postordered_lm_iteration).c_str(),
        ratio(r.dynamic_lm_iteration).c_str(), r.peak_gb);
    out << StringPrintf(
               "         analysis %.3f s (%s, once per mesh); lm_iter = evaluation %.2f + linear "
               "solver %.2f + other %.2f; gradient = assembly %.2f + factorization %.2f + solve "
               "%.2f + accumulation %.2f\n"
               "         svd per element at the solution: %.0f ns, Eigen's JacobiSVD %.0f ns "
               "(%.2fx)\n",
               r.analysis, r.ordering.c_str(), r.lm_evaluation / r.unit,
               r.lm_linear_solver / r.unit,
               (r.lm_iteration - r.lm_evaluation - r.lm_linear_solver) / r.unit,
               r.gradient_assembly / r.unit, r.gradient_factorization / r.unit,
               r.gradient_solve / r.unit, r.gradient_accumulation / r.unit, r.svd_ns,
               r.svd_reference_ns, r.svd_reference_ns / r.svd_ns)
        << std::flush;
  }
  out << "Ratios are to 'unit', one CHOLMOD numeric factorization of the same rest stiffness "
         "(best of 2), measured in this run.\nLM: Levenberg-Marquardt (Ceres) only; "
         "solve/warm: the default method, (L-BFGS iterations + factorizations).\n"
      << BlasDescription() << "\n";
  if (options.csv.empty()) return JobStatus::kOk;
  std::string csv =
      "elements,dofs,factor_nonzeros,ordering,analysis_s,unit_s,lm_iteration_s,lm_solve_s,"
      "lm_solve_iterations,lm_warm_s,lm_warm_iterations,solve_s,solve_lbfgs_iterations,"
      "solve_factorizations,warm_s,warm_lbfgs_iterations,warm_factorizations,gradient_s,"
      "gradient_assembly_s,gradient_factorization_s,gradient_solve_s,gradient_accumulation_s,"
      "ceres_default_lm_iteration_s,ceres_default_postordered_lm_iteration_s,"
      "dynamic_lm_iteration_s,peak_gb,svd_ns,svd_reference_ns\n";
  for (const LatticeBenchmarkRow& r : rows) {
    csv += StringPrintf(
        "%d,%d,%.6g,%s,%.6g,%.6g,%.6g,%.6g,%d,%.6g,%d,%.6g,%d,%d,%.6g,%d,%d,%.6g,%.6g,"
        "%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n",
        r.elements, r.dofs, r.factor_nonzeros, r.ordering.c_str(), r.analysis, r.unit,
        r.lm_iteration, r.lm_solve, r.lm_solve_iterations, r.lm_warm, r.lm_warm_iterations, r.solve,
        r.solve_lm, r.solve_newton, r.warm, r.warm_lm, r.warm_newton, r.gradient,
        r.gradient_assembly, r.gradient_factorization, r.gradient_solve, r.gradient_accumulation,
        r.static_lm_iteration, r.static_postordered_lm_iteration, r.dynamic_lm_iteration, r.peak_gb,
        r.svd_ns, r.svd_reference_ns);
  }
  return WriteFileAtomically(options.csv, csv, error) ? JobStatus::kOk : JobStatus::kBadInput;
}

}  // namespace aqs
