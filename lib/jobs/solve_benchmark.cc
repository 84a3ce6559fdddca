#include "jobs/solve_benchmark.h"

#include <algorithm>
#include <memory>

#include "equilibrium/embedded_attachments.h"
#include "equilibrium/quasistatic_solver.h"
#include "geometry/points_near_model.h"
#include "jobs/model_pose.h"
#include "mesh/lattice.h"
#include "model/model_io.h"
#include "model/surface_springs.h"
#include "prepare/volumetric_targets.h"
#include "util/atomic_file.h"
#include "util/input_file.h"
#include "util/option_checks.h"
#include "util/machine_info.h"
#include "util/string_format.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

struct Case {
  std::string name;
  const ShapeTargetModel* physics = nullptr;
  BoundaryConditions bc;
  ActuationMatrix actuation;
  Eigen::Matrix3Xd rest;
  // With springs: prepare's embedded-simulation springs and their targets.
  std::shared_ptr<EmbeddedAttachments> springs;
  Eigen::Matrix3Xd spring_targets;
};

struct Row {
  std::string name, method;
  int elements = 0;
  double unit = 0;
  QuasistaticSolveReport report;
  double difference = 0;  // relative to the bounding-box diagonal
};

bool ParseMethod(const std::string& name, EquilibriumMethod* method) {
  if (name == "newton") {
    *method = EquilibriumMethod::kNewton;
  } else if (name == "lm") {
    *method = EquilibriumMethod::kLevenbergMarquardt;
  } else {
    return false;
  }
  return true;
}

// Median seconds of three numeric factorizations of the exact stiffness at rest.
double FactorizationSeconds(const Case& c, int num_threads) {
  StiffnessFactorization factorization(*c.physics, FixedVertexMask(c.bc, c.physics->num_vertices()),
                                       num_threads);
  std::string error;
  std::vector<double> seconds;
  factorization.Assemble(c.rest, IdentityActuations(c.physics->num_elements()),
                         StiffnessKind::kExact);
  for (int i = 0; i < 4; ++i) {
    WallTimer timer;
    if (!factorization.FactorizeAssembled(0.0, &error)) return 0.0;
    if (i > 0) seconds.push_back(timer.Seconds());  // the first one includes the analysis
  }
  std::sort(seconds.begin(), seconds.end());
  return seconds[1];
}

void RunCase(const SolveBenchmarkOptions& options, const Case& c, std::ostream& out,
             std::vector<Row>* rows) {
  const double unit = FactorizationSeconds(c, options.num_threads);
  const double size = ModelSize(c.rest);
  Eigen::Matrix3Xd reference;
  for (const std::string& name : options.methods) {
    QuasistaticSolverOptions solver_options;
    ParseMethod(name, &solver_options.method);
    solver_options.relative_force_tolerance = options.tolerance;
    solver_options.max_iterations = options.max_iterations;
    solver_options.num_threads = options.num_threads;
    QuasistaticSolver solver(*c.physics, c.bc, solver_options);
    if (c.springs) {
      c.springs->targets() = c.spring_targets;
      solver.AddEnergyTerm(c.springs.get());
    }
    solver.actuation() = c.actuation;
    solver.SetPositions(c.rest);
    Row row;
    row.name = c.name;
    row.method = name;
    row.elements = c.physics->num_elements();
    row.unit = unit;
    row.report = solver.Solve();
    if (reference.cols() == 0) reference = solver.positions();
    row.difference = (solver.positions() - reference).colwise().norm().maxCoeff() / size;
    const QuasistaticSolveReport& r = row.report;
    out << StringPrintf("%-22s %7d %-7s %-4s %5d %6d %4d+%-4d %5d %9.2f %9.1f %10.2e   ",
                        c.name.c_str(), row.elements, name.c_str(), r.converged ? "yes" : "NO",
                        r.factorizations, r.lbfgs_iterations, r.projected_steps, r.exact_steps,
                        r.lm_iterations, r.seconds, unit > 0 ? r.seconds / unit : 0.0,
                        row.difference)
        << r.termination << "\n"
        << std::flush;
    rows->push_back(row);
  }
}

Case BarCase(const SolveBenchmarkOptions& options, TetMesh* mesh,
             std::unique_ptr<ShapeTargetModel>* physics) {
  LatticeOptions lattice;
  lattice.nx = options.lattice[0], lattice.ny = options.lattice[1], lattice.nz = options.lattice[2];
  lattice.spacing = options.spacing;
  *mesh = MakeLatticeMesh(lattice);
  *physics = std::make_unique<ShapeTargetModel>(*mesh, 1.0);
  Case c;
  c.name = "lattice_curl";
  c.physics = physics->get();
  c.rest = mesh->vertices;
  for (int v = 0; v < mesh->num_vertices(); ++v) {
    if (mesh->vertices(0, v) < 1e-9 * options.spacing) c.bc.vertices.push_back(v);
  }
  c.actuation = IdentityActuations(mesh->num_tets());
  const double middle = 0.5 * options.lattice[1] * options.spacing;
  for (int e = 0; e < mesh->num_tets(); ++e) {
    double y = 0;
    for (int k = 0; k < 4; ++k) y += 0.25 * mesh->vertices(1, mesh->tets(k, e));
    c.actuation(0, e) = y > middle ? 1.0 - options.curl : 1.0 + options.curl;
  }
  return c;
}

// The model's cases (poses, then latents) into *cases, a latent file's warning in `out`;
// false with *error naming the bad pose or latent file.
bool ModelCases(const SolveBenchmarkOptions& options, const ActiveModel& model,
                const ShapeTargetModel& physics, std::vector<Case>* cases, std::ostream& out,
                std::string* error) {
  for (const std::string& name : options.poses) {
    const int p = model.PoseIndex(name);
    if (p < 0) {
      *error = "poses: the model has no training pose '" + name + "'";
      return false;
    }
    Case c;
    c.name = name;
    c.physics = &physics;
    c.rest = model.mesh.vertices;
    c.bc = PoseBoundaryConditions(model, p);
    if (options.springs) {
      c.name += "(springs)";
      c.actuation = IdentityActuations(model.mesh.num_tets());
      c.springs = std::make_shared<EmbeddedAttachments>(
          model.embedding, model.mesh.tets,
          SurfaceSpringStiffness(model, options.attachment_stiffness), model.mesh.vertices);
      c.spring_targets = model.poses[p].surface;
    } else if (model.decoder) {
      DecoderWorkspace workspace;
      model.decoder->Decode(model.decoder_params.data(), model.latents.col(p), &c.actuation,
                            &workspace);
    } else if (model.poses[p].target.cols() == model.mesh.num_tets()) {
      c.actuation = model.poses[p].target;
      c.name += "(target)";
    } else {
      *error = "pose '" + name + "' has neither a decoder nor a volumetric target";
      return false;
    }
    cases->push_back(c);
  }
  for (const auto& [name, file] : options.latents) {
    if (!model.decoder) {
      *error = "latents: '" + name + "=" + file + "' needs a trained model";
      return false;
    }
    Case c;
    c.name = name;
    c.physics = &physics;
    c.rest = model.mesh.vertices;
    ModelPose pose;
    if (!ResolveModelPose(model, file, "", &pose, error)) return false;
    if (!pose.warning.empty()) out << "warning: " << pose.warning << "\n";
    c.bc = ModelBoundaryConditions(model, pose.bones);
    DecoderWorkspace workspace;
    model.decoder->Decode(model.decoder_params.data(), pose.latent, &c.actuation, &workspace);
    cases->push_back(c);
  }
  return true;
}

}  // namespace

bool SolveBenchmarkOptions::Validate(std::string* error) const {
  std::string bad_method;
  EquilibriumMethod unused;
  for (const std::string& m : methods) {
    if (!ParseMethod(m, &unused)) bad_method = m;
  }
  bool cubes_ok = lattice.empty() || lattice.size() == 3;
  for (int n : lattice) cubes_ok = cubes_ok && n >= 1;
  std::string lattice_error;
  bool lattice_ok = true;
  double elements = 0.0;
  if (cubes_ok && !lattice.empty()) {
    LatticeOptions options;
    options.nx = lattice[0], options.ny = lattice[1], options.nz = lattice[2];
    options.spacing = spacing;
    lattice_ok = options.Validate(&lattice_error);
    elements = 6.0 * lattice[0] * lattice[1] * lattice[2];
  }
  OptionChecks checks;
  checks.Require(!methods.empty(), "methods must name a method (newton, lm)")
      .Require(bad_method.empty(), "methods: '" + bad_method + "' is not newton or lm")
      .Require(cubes_ok, "lattice must be three positive cube counts, e.g. 40,4,4")
      .Require(lattice_ok, "lattice, spacing: " + lattice_error)
      .Require(curl >= 0.0 && curl < 1.0,
               "curl must be in [0, 1) (the fibres contract by 1 - curl), is " + OptionValue(curl))
      .Positive("tolerance", tolerance)
      .ReachableTolerance("tolerance", tolerance)
      .IntAtLeast("max_iterations", max_iterations, 1)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .Positive("attachment_stiffness", attachment_stiffness)
      .InRange("attachment_stiffness", attachment_stiffness, 0.0, kMaxRelativeStiffness)
      .Positive("max_memory_bytes", max_memory_bytes);
  if (!checks.Done(error)) return false;
  return elements == 0.0 ||
         CheckMemoryEstimate(EquilibriumSolverMemoryBytes(elements), max_memory_bytes,
                             "the lattice's solves",
                             std::to_string(static_cast<long long>(elements)) + " elements", error);
}

JobStatus RunSolveBenchmark(const SolveBenchmarkOptions& options, std::ostream& out,
                            std::string* error) {
  if (!options.Validate(error)) return JobStatus::kBadInput;
  if (!options.csv.empty() && !CheckOutputFile(options.csv, error)) {
    *error = "csv: " + *error;
    return JobStatus::kBadInput;
  }
  // Every input before the first solve.
  ActiveModel model;
  std::unique_ptr<ShapeTargetModel> model_physics;
  std::vector<Case> cases;
  if (!options.model.empty()) {
    if (!LoadModel(options.model, &model, error)) return JobStatus::kBadInput;
    model_physics = std::make_unique<ShapeTargetModel>(model.mesh, model.mu);
    if (!ModelCases(options, model, *model_physics, &cases, out, error)) {
      return JobStatus::kBadInput;
    }
  }
  out << BenchmarkMachineLine() << "\n";
  out << StringPrintf("%-22s %7s %-7s %-4s %5s %6s %9s %5s %9s %9s %10s\n", "case", "elems",
                      "method", "conv", "fact", "lbfgs", "newton", "lm", "seconds", "s/fact",
                      "diff/size");
  std::vector<Row> rows;
  if (!options.lattice.empty()) {
    TetMesh mesh;
    std::unique_ptr<ShapeTargetModel> physics;
    RunCase(options, BarCase(options, &mesh, &physics), out, &rows);
  }
  for (const Case& c : cases) RunCase(options, c, out, &rows);
  if (!options.csv.empty()) {
    std::string csv =
        "case,elements,method,converged,factorizations,lbfgs_iterations,projected_steps,"
        "exact_steps,lm_iterations,seconds,factorization_seconds,seconds_per_factorization,"
        "difference_over_size\n";
    for (const Row& row : rows) {
      const QuasistaticSolveReport& r = row.report;
      csv += row.name + StringPrintf(",%d,%s,%d,%d,%d,%d,%d,%d,%.6f,%.6f,%.3f,%.3e\n", row.elements,
                                     row.method.c_str(), r.converged ? 1 : 0, r.factorizations,
                                     r.lbfgs_iterations, r.projected_steps, r.exact_steps,
                                     r.lm_iterations, r.seconds, row.unit,
                                     row.unit > 0 ? r.seconds / row.unit : 0.0, row.difference);
    }
    if (!WriteFileAtomically(options.csv, csv, error)) return JobStatus::kBadInput;
  }
  return JobStatus::kOk;
}

}  // namespace aqs
