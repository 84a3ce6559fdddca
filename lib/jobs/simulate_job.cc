#include "jobs/simulate_job.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include <Eigen/LU>

#include "fit/latent_fit.h"
#include "geometry/points_near_model.h"
#include "io/actuation_io.h"
#include "io/vertex_list_io.h"
#include "jobs/deformed_output.h"
#include "jobs/model_pose.h"
#include "mesh/element_subset.h"
#include "mesh/mesh_io.h"
#include "mesh/tet_components.h"
#include "model/model_io.h"
#include "prepare/volumetric_targets.h"
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

// There are outputs, of known kinds (.mesh, .vtu, .obj), and every output path (and the
// gradient's) can be written and is none of the inputs (nor inside the model): checked
// before any work.
bool CheckOutputs(const SimulateJobOptions& options, std::string* error) {
  if (options.outputs.empty()) {
    *error = "no output given (--output)";
    return false;
  }
  for (const std::string& output : options.outputs) {
    if (!IsDeformedMeshOutputPath(output)) {
      *error = output + ": unknown output extension; known: .mesh, .vtu, .obj";
      return false;
    }
  }
  std::vector<std::string> outputs = options.outputs;
  if (!options.gradient.empty()) outputs.push_back(options.gradient);
  if (!CheckOutputsDistinct(outputs, error)) return false;
  for (const std::string& output : outputs) {
    if (!CheckOutputFile(output, error)) return false;
    for (const std::string* input :
         {&options.model, &options.mesh, &options.fixed, &options.actuation, &options.initial,
          &options.loss_target, &options.mu_per_element, &options.latent}) {
      if (!CheckOutputApart(output, *input, error)) return false;
    }
  }
  return true;
}

// The elements inverted or flat (det F <= 0) at the state x (3 x num_vertices), and
// the first of them (-1: none) into *first.
int CountInvertedElements(const ShapeTargetModel& model, const Eigen::Matrix3Xd& x,
                          int* first) {
  int inverted = 0;
  *first = -1;
  for (int e = 0; e < model.num_elements(); ++e) {
    if (model.DeformationGradient(x, e).determinant() > 0.0) continue;
    if (inverted++ == 0) *first = e;
  }
  return inverted;
}

// A warning line if elements are inverted or flat (det F <= 0) at the state x: an
// "equilibrium" with inverted elements is rarely what was meant. With the training
// poses' equilibria (`training_states`; empty ones skipped), a note instead where no
// more are inverted than in one of them (a trained model reproduces its targets'
// inversions: --inverted_targets=exact).
void WarnInvertedElements(const ShapeTargetModel& model, const Eigen::Matrix3Xd& x,
                          std::ostream& log,
                          const std::vector<Eigen::Matrix3Xd>* training_states = nullptr) {
  int first = -1;
  const int inverted = CountInvertedElements(model, x, &first);
  if (inverted == 0) return;
  int training_most = -1;
  if (training_states != nullptr) {
    for (const Eigen::Matrix3Xd& state : *training_states) {
      if (state.cols() != x.cols()) continue;
      int unused = -1;
      training_most = std::max(training_most, CountInvertedElements(model, state, &unused));
    }
  }
  const bool usual = training_most >= 0 && inverted <= training_most;
  log << (usual ? "note: " : "warning: ") << inverted << " of " << model.num_elements()
      << " elements are inverted or flat (det F <= 0) in the result (the first is element "
      << first << ")";
  if (training_most >= 0) {
    log << "; the training poses' equilibria have up to " << training_most;
  }
  log << "\n";
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
      !options.loss_target.empty() || !options.mu_per_element.empty() ||
      !options.gradient.empty() || !options.initial.empty()) {
    return Fail(JobStatus::kBadInput,
                "with --model, the mesh, material, boundary conditions and actuation come from "
                "the model: --mesh, --fixed, --actuation, --mu_per_element, --loss_target, "
                "--gradient and --initial do not apply");
  }
  if (options.latent.empty() == options.pose.empty()) {
    return Fail(JobStatus::kBadInput, "with --model, give either --latent=Z.txt or --pose=NAME");
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
  if (!pose.warning.empty()) log << "warning: " << pose.warning << "\n";
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
    // Trained models reproduce inverted targets (--inverted_targets=exact): their own
    // latents decode to some such elements, which is no sign of a latent out of range.
    int training_most = 0;
    ActuationMatrix training;
    for (Eigen::Index p = 0; p < model.latents.cols(); ++p) {
      model.decoder->Decode(model.decoder_params.data(), model.latents.col(p), &training,
                            &workspace);
      training_most = std::max(training_most, CountNonPositiveDefinite(training));
    }
    log << (not_positive > training_most ? "warning: " : "note: ") << "the decoded actuation of "
        << not_positive << " of " << a.cols() << " elements is not positive definite (the "
        << "first is element " << first_bad << "; the training latents decode to at most "
        << training_most << " such elements)"
        << (not_positive > training_most ? ": the latent is far from the training latents?"
                                         : "")
        << "\n";
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
  WarnInvertedElements(physics, state, log, &model.states);
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


// Mesh mode's inputs, read and checked.
struct MeshSimulation {
  TetMesh mesh;
  Eigen::VectorXd mu;           // per element
  BoundaryConditions bc;        // empty: a free body
  ActuationMatrix actuation;    // 6 x elements (identity unless --actuation)
  Eigen::Matrix3Xd initial;     // the solve's start (the mesh's rest state unless --initial)
  Eigen::Matrix3Xd loss_target; // with --loss_target (else empty)
};

// The vertices of the tet mesh file `path` (a start or a target) into *vertices; it must
// have the mesh's vertex count.
bool ReadStateOfMesh(const std::string& path, const TetMesh& mesh, Eigen::Matrix3Xd* vertices,
                     std::string* error) {
  TetMesh state;
  if (!ReadTetMeshFile(path, &state, error)) return false;
  if (state.num_vertices() != mesh.num_vertices()) {
    std::ostringstream out;
    out << path << ": " << state.num_vertices() << " vertices, but the mesh has "
        << mesh.num_vertices();
    *error = out.str();
    return false;
  }
  // Far from the mesh, a start or a target overflows the energy or the loss (a vertex at
  // 1e200 gave loss inf and an infinite gradient with exit 0).
  if (!CheckPointsNearModel(path, mesh.vertices, state.vertices, error)) return false;
  *vertices = state.vertices;
  return true;
}

// The per-element stiffness: --mu, or --mu_per_element's file (one per line; a contrast
// above kMaxStiffnessContrast is refused).
bool ReadStiffness(const SimulateJobOptions& options, int num_elements, Eigen::VectorXd* mu,
                   std::string* error) {
  *mu = Eigen::VectorXd::Constant(num_elements, options.mu);
  if (options.mu_per_element.empty()) return true;
  if (!ReadScalarsPerLine(options.mu_per_element, num_elements, true, mu, error)) return false;
  if (!(mu->maxCoeff() / mu->minCoeff() <= kMaxStiffnessContrast)) {
    std::ostringstream out;
    out << options.mu_per_element << ": the stiffness ranges from " << mu->minCoeff() << " to "
        << mu->maxCoeff() << ", a contrast above " << kMaxStiffnessContrast
        << " that no solve resolves in double precision";
    *error = out.str();
    return false;
  }
  return true;
}

// Reads and checks mesh mode's inputs (all before any work), logging what was read.
bool ReadMeshSimulation(const SimulateJobOptions& options, MeshSimulation* in,
                        std::ostream& log, std::string* error) {
  if (!ReadTetMesh(options.mesh, &in->mesh, error)) return false;
  const TetMesh& mesh = in->mesh;
  log << "mesh " << options.mesh << ": " << mesh.num_vertices() << " vertices, "
      << mesh.num_tets() << " elements\n";
  if (!ReadStiffness(options, mesh.num_tets(), &in->mu, error)) return false;
  if (!options.fixed.empty()) {
    if (!ReadFixedVertices(options.fixed, mesh.vertices, &in->bc, error)) return false;
    if (in->bc.vertices.empty()) {
      *error = options.fixed + ": lists no vertices";
      return false;
    }
    log << "fixed " << options.fixed << ": " << in->bc.vertices.size() << " vertices\n";
  } else {
    log << "no fixed vertices: the body is free (the equilibrium is defined up to a rigid "
           "motion; gradients need fixed vertices)\n";
  }
  // A free vertex that no element uses has no stiffness: every equilibrium's K would be
  // singular there (10-node tets' mid-edge nodes, whose elements are read by their corners;
  // points or curves a mesher keeps).
  std::vector<bool> fixed(mesh.num_vertices(), false);
  for (int v : in->bc.vertices) fixed[v] = true;
  if (!options.fixed.empty() && !EveryPieceIsHeld(mesh, fixed, error)) {
    *error = options.mesh + " with " + options.fixed + ": " + *error;
    return false;
  }
  const std::vector<int> uses = VertexElementCounts(mesh);
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (uses[v] == 0 && !fixed[v]) {
      *error = options.mesh + ": vertex " + std::to_string(v) + " (0-based) is used by no "
               "element, and a free vertex without an element has no stiffness (the mid-edge "
               "nodes of 10-node tets are such vertices): write the mesh with 4-node tets and "
               "only the nodes they use, or give it to aqs_prepare --tet_mesh, which drops them";
      return false;
    }
  }
  in->actuation = IdentityActuations(mesh.num_tets());
  if (!options.actuation.empty()) {
    if (!ReadActuationTargets(options.actuation, mesh.num_tets(), &in->actuation, error)) {
      return false;
    }
    log << "actuation " << options.actuation << "\n";
  }
  in->initial = mesh.vertices;
  if (!options.initial.empty() && !ReadStateOfMesh(options.initial, mesh, &in->initial, error)) {
    return false;
  }
  if (!options.loss_target.empty() &&
      !ReadStateOfMesh(options.loss_target, mesh, &in->loss_target, error)) {
    return false;
  }
  if (in->bc.vertices.empty() && options.solver.method == EquilibriumMethod::kNewton) {
    *error = "no fixed vertices (--fixed): a free body's stiffness is singular, so Newton's "
             "method cannot solve it; fix some vertices, or use --solver=lm (the "
             "equilibrium is then defined up to a rigid motion, with no gradient)";
    return false;
  }
  return true;
}

// The loss's gradient dL/da at the solver's equilibrium x (L = 1/2 |x - target|^2), by
// one differentiation sharing the solver's factorization, written to options.gradient
// and added to the cells' fields. Where it cannot be had, result's status and message
// say why; false (with *error) only if the file cannot be written.
bool WriteLossGradient(const SimulateJobOptions& options, const MeshSimulation& in,
                       QuasistaticSolver* solver, const Eigen::Matrix3Xd& x,
                       std::vector<VtuField>* cell_fields, SimulateJobResult* result,
                       std::ostream& log, std::string* error) {
  WallTimer timer;
  // Shares the solver's stiffness factorization (one CHOLMOD factor in memory).
  EquilibriumDifferentiator differentiator(
      solver->stiffness_factorization(),
      EquilibriumDifferentiatorOptions{options.solver.num_threads});
  if (in.bc.vertices.empty()) {
    result->status = JobStatus::kDifferentiationFailed;
    result->message =
        "no gradient: a free body's stiffness is singular; fix some vertices (--fixed)";
    return true;
  }
  std::string prepare_error;
  if (!differentiator.Prepare(x, in.actuation, &prepare_error)) {
    result->status = JobStatus::kDifferentiationFailed;
    result->message = "no gradient: " + prepare_error;
    return true;
  }
  const ActuationMatrix gradient = differentiator.LossGradient(x - in.loss_target);
  const DifferentiationTimings& t = differentiator.timings();
  log << "gradient: |dL/da| = " << gradient.norm() << " in " << timer.Seconds()
      << " s (assembly " << t.assembly << ", analysis " << t.analysis << ", factorization "
      << t.factorization << ", solve " << t.solve << ", accumulation " << t.accumulation
      << ")\n";
  if (!WriteActuation(options.gradient, gradient,
                      "dL/d(sxx syy szz sxy sxz syz) per element, L = 1/2 sum_v |x_v - y_v|^2"
                      "\nmesh " + options.mesh + ", target " + options.loss_target,
                      error)) {
    return false;
  }
  log << "wrote " << options.gradient << "\n";
  cell_fields->push_back(MakeVtuField("dL_da", gradient));
  return true;
}

// Mesh mode: a tet mesh, its material, boundary conditions and actuation from files.
SimulateJobResult RunMeshSimulateJob(const SimulateJobOptions& options, std::ostream& log) {
  WallTimer total;
  std::string error;
  // ---- Inputs (all checked before any work) ----
  if (options.mesh.empty()) return Fail(JobStatus::kBadInput, "no mesh given (--mesh)");
  if (!options.gradient.empty() && options.loss_target.empty()) {
    return Fail(JobStatus::kBadInput, "--gradient needs --loss_target (the loss to differentiate)");
  }
  if (!CheckOutputs(options, &error)) return Fail(JobStatus::kBadInput, error);
  MeshSimulation in;
  if (!ReadMeshSimulation(options, &in, log, &error)) return Fail(JobStatus::kBadInput, error);
  const TetMesh& mesh = in.mesh;
  std::ostringstream details;
  details << mesh.num_tets() << " elements"
          << (options.gradient.empty() ? "" : ", and the adjoint");
  if (!CheckMemoryEstimate(
          EquilibriumSolverMemoryBytes(mesh.num_tets()) * (options.gradient.empty() ? 1 : 2),
          options.max_memory_bytes, "the equilibrium solve", details.str(), &error)) {
    return Fail(JobStatus::kBadInput, error);
  }

  // ---- Solve ----
  const ShapeTargetModel model(mesh, in.mu);
  if (!(std::isfinite(model.force_scale()) && model.force_scale() > 0.0)) {
    std::ostringstream out;
    out << "the force scale 2 mean(mu V^(2/3)) of the mesh is " << model.force_scale()
        << ": mu (" << (options.mu_per_element.empty() ? "mu" : options.mu_per_element)
        << ") or the mesh's size is so large or small that the forces overflow";
    return Fail(JobStatus::kBadInput, out.str());
  }
  QuasistaticSolver solver(model, in.bc, options.solver);
  solver.actuation() = in.actuation;
  solver.SetPositions(in.initial);
  SimulateJobResult result;
  result.solve = solver.Solve();
  log << "solve: " << result.solve.Summary() << "\n";
  WarnUnstable(result.solve, log);
  const Eigen::Matrix3Xd x = solver.positions();
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
  model.EnergyAndGradient(x, in.actuation, &energy_gradient, options.solver.num_threads);
  point_fields.push_back(MakeVtuField("residual_force", -energy_gradient));
  ElementFields(model, x, in.actuation, &cell_fields);
  if (!options.loss_target.empty()) {
    result.has_loss = true;
    result.loss = 0.5 * (x - in.loss_target).squaredNorm();
    log << std::setprecision(17) << "loss " << result.loss << std::setprecision(6) << "\n";
    if (!options.gradient.empty() && result.status == JobStatus::kOk) {
      if (!WriteLossGradient(options, in, &solver, x, &cell_fields, &result, log, &error)) {
        return Fail(JobStatus::kBadInput, error);
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

}  // namespace

bool SimulateJobOptions::Validate(std::string* error) const {
  std::string solver_error;
  const bool solver_ok = solver.Validate(&solver_error);
  return OptionChecks()
      .Positive("mu", mu)
      .Positive("max_memory_bytes", max_memory_bytes)
      .Nested("solver", solver_ok, solver_error)
      .ReachableTolerance("solver.relative_force_tolerance", solver.relative_force_tolerance)
      .Done(error);
}

SimulateJobResult RunSimulateJob(const SimulateJobOptions& options, std::ostream& log) {
  std::string error;
  if (!options.Validate(&error)) return Fail(JobStatus::kBadInput, error);
  return options.model.empty() ? RunMeshSimulateJob(options, log)
                               : RunModelSimulateJob(options, log);
}

}  // namespace aqs
