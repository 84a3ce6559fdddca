#include "jobs/simulate_job.h"

#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include <Eigen/LU>

#include "fit/latent_fit.h"
#include "io/actuation_io.h"
#include "model/model_io.h"
#include "io/vertex_list_io.h"
#include "jobs/deformed_output.h"
#include "jobs/model_pose.h"
#include "mesh/mesh_io.h"
#include "util/file_extension.h"
#include "util/input_file.h"
#include "util/option_checks.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

SimulateJobResult Fail(JobStatus status, const std::string& message) {
  SimulateJobResult result;
  result.status = status;
  result.message = message;
  return result;
}

// Every output path (and the gradient's) can be written: checked before any work.
bool CheckOutputs(const SimulateJobOptions& options, std::string* error) {
  for (const std::string& output : options.outputs) {
    if (!CheckOutputFile(output, error)) return false;
  }
  return options.gradient.empty() || CheckOutputFile(options.gradient, error);
}

// A warning line if elements are inverted or flat (det F <= 0) at the state x: an
// "equilibrium" with inverted elements is rarely what was meant.
void WarnInvertedElements(const ShapeTargetModel& model, const Eigen::Matrix3Xd& x,
                          std::ostream& log) {
  int inverted = 0, first = -1;
  for (int e = 0; e < model.num_elements(); ++e) {
    if (model.DeformationGradient(x, e).determinant() > 0.0) continue;
    if (inverted++ == 0) first = e;
  }
  if (inverted > 0) {
    log << "warning: " << inverted << " of " << model.num_elements()
        << " elements are inverted or flat (det F <= 0) in the result (the first is element "
        << first << ")\n";
  }
}

// A warning line if the solve's stability check (--ensure_stable) found the result to
// be an unstable equilibrium it could not leave.
void WarnUnstable(const QuasistaticSolveReport& solve, std::ostream& log) {
  if (solve.converged && solve.stability_checked && !solve.stable) {
    log << "warning: the result is an unstable equilibrium (zero force, but the exact "
           "stiffness is not positive definite: a saddle of the energy, not a rest state)\n";
  }
}

// Per-element fields for the VTU output: actuation, energy density, det F.
void ElementFields(const ShapeTargetModel& model, const Eigen::Matrix3Xd& x,
                   const ActuationMatrix& a, std::vector<VtuField>* cell_fields) {
  Eigen::MatrixXd energy(1, model.num_elements()), volume_ratio(1, model.num_elements());
  for (int e = 0; e < model.num_elements(); ++e) {
    const ShapeTargetElement element = model.Element(x, a, e);
    energy(0, e) = element.EnergyDensity();
    volume_ratio(0, e) = element.f().determinant();
  }
  cell_fields->push_back(MakeVtuField("actuation", a));
  cell_fields->push_back(MakeVtuField("energy_density", energy));
  cell_fields->push_back(MakeVtuField("volume_ratio", volume_ratio));
}

// Model mode: decode a latent of a trained model and simulate.
SimulateJobResult RunModelSimulateJob(const SimulateJobOptions& options, std::ostream& log) {
  WallTimer total;
  std::string error;
  if (!options.mesh.empty() || !options.fixed.empty() || !options.actuation.empty() ||
      !options.loss_target.empty() || !options.mu_per_element.empty()) {
    return Fail(JobStatus::kBadInput,
                "with --model, the mesh, material, boundary conditions and actuation come from "
                "the model: --mesh, --fixed, --actuation, --mu_per_element and --loss_target "
                "do not apply");
  }
  if (options.latent.empty() == options.pose.empty()) {
    return Fail(JobStatus::kBadInput, "with --model, give either --latent=Z.txt or --pose=NAME");
  }
  if (options.outputs.empty()) return Fail(JobStatus::kBadInput, "no output given (--output)");
  for (const std::string& output : options.outputs) {
    if (!IsDeformedMeshOutputPath(output)) {
      return Fail(JobStatus::kBadInput,
                  output + ": unknown output extension; known: .mesh, .vtu, .obj");
    }
  }
  if (!CheckOutputs(options, &error)) return Fail(JobStatus::kBadInput, error);
  ActiveModel model;
  if (!LoadModel(options.model, &model, &error)) return Fail(JobStatus::kBadInput, error);
  if (!model.decoder) {
    return Fail(JobStatus::kBadInput, options.model + ": the model is not trained (no decoder)");
  }
  ModelPose pose;
  if (!ResolveModelPose(model, options.latent, options.pose, &pose, &error)) {
    return Fail(JobStatus::kBadInput, error);
  }
  LatentFitOptions fit_options;
  fit_options.solver = options.solver;
  fit_options.num_threads = options.solver.num_threads;
  LatentFitter fitter(model, fit_options);
  fitter.set_bone_transforms(pose.bones);
  // A training pose starts from the equilibrium training left (the energy is not convex;
  // from rest the solve may take another branch or crawl).
  if (pose.training_pose >= 0 && !options.from_rest) fitter.StartFromTrainingPose(pose.training_pose);
  Eigen::Matrix3Xd state, surface;
  SimulateJobResult result;
  ActuationMatrix a;
  DecoderWorkspace workspace;
  model.decoder->Decode(model.decoder_params.data(), pose.latent, &a, &workspace);
  int first_bad = -1;
  const int not_positive = CountNonPositiveDefinite(a, &first_bad);
  if (not_positive > 0) {
    log << "warning: the decoded actuation of " << not_positive << " of " << a.cols()
        << " elements is not positive definite (the first is element " << first_bad
        << "): the latent is far from the training latents?\n";
  }
  if (!fitter.Simulate(pose.latent, &state, &surface, &error)) {
    result.status = JobStatus::kNotConverged;
    result.message = error;
  }
  result.solve = fitter.last_simulate_report();
  log << "simulated the model " << options.model << " ("
      << (options.pose.empty() ? "latent " + options.latent : "pose " + options.pose) << "): "
      << model.mesh.num_tets() << " elements\nsolve: " << result.solve.Summary() << "\n";
  WarnUnstable(result.solve, log);
  if (!state.allFinite()) {
    // Nothing to inspect: no output rather than a file of NaNs.
    result.status = JobStatus::kNotConverged;
    result.message = "the equilibrium was not reached and the state is not finite; no output "
                     "written: " + result.solve.Summary();
    return result;
  }
  const ShapeTargetModel physics(model.mesh, model.mu);
  WarnInvertedElements(physics, state, log);
  std::vector<VtuField> point_fields = {MakeVtuField("displacement", state - model.mesh.vertices)};
  std::vector<VtuField> cell_fields;
  ElementFields(physics, state, a, &cell_fields);
  for (const std::string& output : options.outputs) {
    if (LowercaseExtension(output) == ".obj") {
      SurfaceMesh out = model.neutral;
      out.vertices = surface;
      if (!WriteObj(output, out, &error)) return Fail(JobStatus::kBadInput, error);
    } else if (!WriteDeformedMesh(output, model.mesh, state, point_fields, cell_fields, &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
    log << "wrote " << output << (result.status == JobStatus::kOk ? "" : " (NOT CONVERGED)")
        << "\n";
  }
  log << "total " << total.Seconds() << " s\n";
  return result;
}

}  // namespace

bool SimulateJobOptions::Validate(std::string* error) const {
  std::string solver_error;
  const bool solver_ok = solver.Validate(&solver_error);
  return OptionChecks()
      .Positive("mu", mu)
      .Nested("solver", solver_ok, solver_error)
      .ReachableTolerance("solver.relative_force_tolerance", solver.relative_force_tolerance)
      .Done(error);
}

SimulateJobResult RunSimulateJob(const SimulateJobOptions& options, std::ostream& log) {
  std::string error;
  if (!options.Validate(&error)) return Fail(JobStatus::kBadInput, error);
  if (!options.model.empty()) return RunModelSimulateJob(options, log);
  WallTimer total;
  // ---- Inputs (all checked before any work) ----
  if (options.mesh.empty()) return Fail(JobStatus::kBadInput, "no mesh given (--mesh)");
  if (options.outputs.empty()) return Fail(JobStatus::kBadInput, "no output given (--output)");
  for (const std::string& output : options.outputs) {
    if (!IsDeformedMeshOutputPath(output)) {
      return Fail(JobStatus::kBadInput,
                  output + ": unknown output extension; known: .mesh, .vtu, .obj");
    }
  }
  if (!options.gradient.empty() && options.loss_target.empty()) {
    return Fail(JobStatus::kBadInput, "--gradient needs --loss_target (the loss to differentiate)");
  }
  if (!CheckOutputs(options, &error)) return Fail(JobStatus::kBadInput, error);
  TetMesh mesh;
  if (!ReadTetMesh(options.mesh, &mesh, &error)) return Fail(JobStatus::kBadInput, error);
  log << "mesh " << options.mesh << ": " << mesh.num_vertices() << " vertices, "
      << mesh.num_tets() << " elements\n";

  Eigen::VectorXd mu = Eigen::VectorXd::Constant(mesh.num_tets(), options.mu);
  if (!options.mu_per_element.empty()) {
    if (!ReadScalarsPerLine(options.mu_per_element, mesh.num_tets(), true, &mu, &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
    if (!(mu.maxCoeff() / mu.minCoeff() <= kMaxStiffnessContrast)) {
      std::ostringstream out;
      out << options.mu_per_element << ": the stiffness ranges from " << mu.minCoeff() << " to "
          << mu.maxCoeff() << ", a contrast above " << kMaxStiffnessContrast
          << " that no solve resolves in double precision";
      return Fail(JobStatus::kBadInput, out.str());
    }
  }
  BoundaryConditions bc;
  if (!options.fixed.empty()) {
    if (!ReadFixedVertices(options.fixed, mesh.vertices, &bc, &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
    if (bc.vertices.empty()) {
      return Fail(JobStatus::kBadInput, options.fixed + ": lists no vertices");
    }
    log << "fixed " << options.fixed << ": " << bc.vertices.size() << " vertices\n";
  } else {
    log << "no fixed vertices: the body is free (the equilibrium is defined up to a rigid "
           "motion; gradients need fixed vertices)\n";
  }
  ActuationMatrix actuation = IdentityActuations(mesh.num_tets());
  if (!options.actuation.empty()) {
    if (!ReadActuationTargets(options.actuation, mesh.num_tets(), &actuation, &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
    log << "actuation " << options.actuation << "\n";
  }
  Eigen::Matrix3Xd initial = mesh.vertices;
  if (!options.initial.empty()) {
    TetMesh start;
    if (!ReadTetMeshFile(options.initial, &start, &error)) return Fail(JobStatus::kBadInput, error);
    if (start.num_vertices() != mesh.num_vertices()) {
      std::ostringstream out;
      out << options.initial << ": " << start.num_vertices() << " vertices, but the mesh has "
          << mesh.num_vertices();
      return Fail(JobStatus::kBadInput, out.str());
    }
    initial = start.vertices;
  }
  TetMesh target;
  if (!options.loss_target.empty()) {
    if (!ReadTetMeshFile(options.loss_target, &target, &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
    if (target.num_vertices() != mesh.num_vertices()) {
      std::ostringstream out;
      out << options.loss_target << ": " << target.num_vertices()
          << " vertices, but the mesh has " << mesh.num_vertices();
      return Fail(JobStatus::kBadInput, out.str());
    }
  }

  if (bc.vertices.empty() && options.solver.method == EquilibriumMethod::kNewton) {
    return Fail(JobStatus::kBadInput,
                "no fixed vertices (--fixed): a free body's stiffness is singular, so Newton's "
                "method cannot solve it; fix some vertices, or use --solver=lm (the "
                "equilibrium is then defined up to a rigid motion, with no gradient)");
  }

  // ---- Solve ----
  const ShapeTargetModel model(mesh, mu);
  if (!(std::isfinite(model.force_scale()) && model.force_scale() > 0.0)) {
    std::ostringstream out;
    out << "the force scale 2 mean(mu V^(2/3)) of the mesh is " << model.force_scale()
        << ": mu (" << (options.mu_per_element.empty() ? "mu" : options.mu_per_element)
        << ") or the mesh's size is so large or small that the forces overflow";
    return Fail(JobStatus::kBadInput, out.str());
  }
  QuasistaticSolver solver(model, bc, options.solver);
  solver.actuation() = actuation;
  solver.SetPositions(initial);
  SimulateJobResult result;
  result.solve = solver.Solve();
  log << "solve: " << result.solve.Summary() << "\n";
  WarnUnstable(result.solve, log);
  Eigen::Matrix3Xd x = solver.positions();

  if (!result.solve.converged) {
    result.status = JobStatus::kNotConverged;
    result.message = "the equilibrium was not reached: " + result.solve.Summary();
  }
  if (!x.allFinite()) {
    result.message += "; the state is not finite: no output written";
    return result;
  }
  WarnInvertedElements(model, x, log);

  // ---- Loss and gradient ----
  std::vector<VtuField> point_fields, cell_fields;
  point_fields.push_back(MakeVtuField("displacement", x - mesh.vertices));
  Eigen::Matrix3Xd energy_gradient;
  model.EnergyAndGradient(x, actuation, &energy_gradient, options.solver.num_threads);
  point_fields.push_back(MakeVtuField("residual_force", -energy_gradient));
  ElementFields(model, x, actuation, &cell_fields);
  if (!options.loss_target.empty()) {
    result.has_loss = true;
    result.loss = 0.5 * (x - target.vertices).squaredNorm();
    log << std::setprecision(17) << "loss " << result.loss << std::setprecision(6) << "\n";
    if (!options.gradient.empty() && result.status == JobStatus::kOk) {
      WallTimer timer;
      // Shares the solver's stiffness factorization (one CHOLMOD factor in memory).
      EquilibriumDifferentiator differentiator(
          solver.stiffness_factorization(),
          EquilibriumDifferentiatorOptions{options.solver.num_threads});
      if (bc.vertices.empty()) {
        result.status = JobStatus::kDifferentiationFailed;
        result.message = "no gradient: a free body's stiffness is singular; fix some vertices (--fixed)";
      } else if (!differentiator.Prepare(x, actuation, &error)) {
        result.status = JobStatus::kDifferentiationFailed;
        result.message = "no gradient: " + error;
      } else {
        const ActuationMatrix gradient = differentiator.LossGradient(x - target.vertices);
        const DifferentiationTimings& t = differentiator.timings();
        log << "gradient: |dL/da| = " << gradient.norm() << " in " << timer.Seconds()
            << " s (assembly " << t.assembly << ", analysis " << t.analysis
            << ", factorization " << t.factorization << ", solve " << t.solve
            << ", accumulation " << t.accumulation << ")\n";
        if (!WriteActuation(options.gradient, gradient,
                            "dL/d(sxx syy szz sxy sxz syz) per element, L = 1/2 sum_v |x_v - y_v|^2"
                            "\nmesh " + options.mesh + ", target " + options.loss_target,
                            &error)) {
          return Fail(JobStatus::kBadInput, error);
        }
        log << "wrote " << options.gradient << "\n";
        cell_fields.push_back(MakeVtuField("dL_da", gradient));
      }
    } else if (!options.gradient.empty()) {
      log << "no gradient written: the equilibrium was not reached\n";
    }
  }

  // ---- Outputs ----
  for (const std::string& output : options.outputs) {
    if (!WriteDeformedMesh(output, mesh, x, point_fields, cell_fields, &error)) {
      return Fail(JobStatus::kBadInput, error);
    }
    log << "wrote " << output << "\n";
  }
  log << "total " << total.Seconds() << " s\n";
  return result;
}

}  // namespace aqs
