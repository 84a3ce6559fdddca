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

#include <algorithm>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <gflags/gflags.h>

#include "app_common.h"
#include "equilibrium/quasistatic_solver.h"
#include "equilibrium/embedded_attachments.h"
#include "jobs/model_pose.h"
#include "prepare/volumetric_targets.h"
#include "mesh/lattice.h"
#include "model/model_io.h"
#include "util/atomic_file.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/memory_limit.h"
#include "util/wall_timer.h"

DEFINE_string(lattice, "40,4,4", "Cubes of the bar lattice along x, y, z (empty: no lattice case).");
DEFINE_double(spacing, 0.25, "Cube edge of the bar lattice.");
DEFINE_double(curl, 0.4, "Fibre contraction (above the middle) and stretch (below) of the bar.");
DEFINE_string(poses, "", "With --model: training poses to solve from rest (comma-separated).");
DEFINE_string(latents, "", "With --model: NAME=FILE pairs (comma-separated) of latent files to "
              "decode and solve from rest, the bones where the file's bone lines put them (at "
              "rest without).");
DEFINE_bool(springs, false, "With --poses: solve prepare's embedded simulation instead (the passive "
            "body, S = I, pulled by springs onto the pose's surface; see aqs_prepare).");
DEFINE_double(attachment_stiffness, 100.0, "With --springs: the springs' relative stiffness.");
DEFINE_string(methods, "newton,lm", "Solver methods to compare (the first is the reference).");
DEFINE_double(tolerance, 1e-6, "Relative force tolerance of the solves.");
DEFINE_int32(max_iterations, 1000, "Iterations at most per solve (factorizations or LM iterations).");
DEFINE_string(csv, "", "Optional CSV file for the figures.");
DECLARE_int32(threads);
DECLARE_string(model);

namespace aqs {
namespace {

struct Case {
  std::string name;
  const ShapeTargetModel* physics;
  BoundaryConditions bc;
  ActuationMatrix actuation;
  Eigen::Matrix3Xd rest;
  // With --springs: prepare's embedded-simulation springs and their targets.
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

// Median seconds of three numeric factorizations of the exact stiffness at rest.
double FactorizationSeconds(const Case& c) {
  StiffnessFactorization factorization(*c.physics, FixedVertexMask(c.bc, c.physics->num_vertices()),
                                       FLAGS_threads);
  std::string error;
  std::vector<double> seconds;
  factorization.Assemble(c.rest, IdentityActuations(c.physics->num_elements()), StiffnessKind::kExact);
  for (int i = 0; i < 4; ++i) {
    WallTimer timer;
    if (!factorization.FactorizeAssembled(0.0, &error)) return 0.0;
    if (i > 0) seconds.push_back(timer.Seconds());  // the first one includes the analysis
  }
  std::sort(seconds.begin(), seconds.end());
  return seconds[1];
}

bool ParseMethod(const std::string& name, EquilibriumMethod* method) {
  if (name == "newton") *method = EquilibriumMethod::kNewton;
  else if (name == "lm") *method = EquilibriumMethod::kLevenbergMarquardt;
  else return false;
  return true;
}

// The table's header, before the first case (after every flag was checked).
void PrintHeaderOnce() {
  static bool printed = false;
  if (printed) return;
  printed = true;
  std::printf("%-22s %7s %-7s %-4s %5s %6s %9s %5s %9s %9s %10s\n", "case", "elems", "method",
              "conv", "fact", "lbfgs", "newton", "lm", "seconds", "s/fact", "diff/size");
}

void RunCase(const Case& c, const std::vector<std::string>& methods, std::vector<Row>* rows) {
  PrintHeaderOnce();
  const double unit = FactorizationSeconds(c);
  const double size = (c.rest.rowwise().maxCoeff() - c.rest.rowwise().minCoeff()).norm();
  Eigen::Matrix3Xd reference;
  for (const std::string& name : methods) {
    QuasistaticSolverOptions options;
    ParseMethod(name, &options.method);
    options.relative_force_tolerance = FLAGS_tolerance;
    options.max_iterations = FLAGS_max_iterations;
    options.num_threads = FLAGS_threads;
    QuasistaticSolver solver(*c.physics, c.bc, options);
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
    std::printf("%-22s %7d %-7s %-4s %5d %6d %4d+%-4d %5d %9.2f %9.1f %10.2e   %s\n", c.name.c_str(),
                row.elements, name.c_str(), r.converged ? "yes" : "NO", r.factorizations,
                r.lbfgs_iterations, r.projected_steps, r.exact_steps, r.lm_iterations, r.seconds,
                unit > 0 ? r.seconds / unit : 0.0, row.difference, r.termination.c_str());
    std::fflush(stdout);
    rows->push_back(row);
  }
}

Case BarCase(const std::vector<int>& cubes, TetMesh* mesh, std::unique_ptr<ShapeTargetModel>* physics) {
  LatticeOptions lattice;
  lattice.nx = cubes[0], lattice.ny = cubes[1], lattice.nz = cubes[2];
  lattice.spacing = FLAGS_spacing;
  *mesh = MakeLatticeMesh(lattice);
  *physics = std::make_unique<ShapeTargetModel>(*mesh, 1.0);
  Case c;
  c.name = "lattice_curl";
  c.physics = physics->get();
  c.rest = mesh->vertices;
  for (int v = 0; v < mesh->num_vertices(); ++v) {
    if (mesh->vertices(0, v) < 1e-9) c.bc.vertices.push_back(v);
  }
  c.actuation = IdentityActuations(mesh->num_tets());
  const double middle = 0.5 * cubes[1] * FLAGS_spacing;
  for (int e = 0; e < mesh->num_tets(); ++e) {
    double y = 0;
    for (int k = 0; k < 4; ++k) y += 0.25 * mesh->vertices(1, mesh->tets(k, e));
    c.actuation(0, e) = y > middle ? 1.0 - FLAGS_curl : 1.0 + FLAGS_curl;
  }
  return c;
}

int Main() {
  std::vector<std::string> methods = SplitList(FLAGS_methods);
  EquilibriumMethod unused;
  for (const std::string& m : methods) {
    if (!ParseMethod(m, &unused)) {
      PrintError("--methods: '" + m + "' is not newton or lm");
      return 1;
    }
  }
  if (methods.empty() || !(FLAGS_tolerance > 0) || FLAGS_max_iterations < 1 || FLAGS_threads < 1) {
    PrintError("--methods must name a method, --tolerance > 0, --max_iterations and --threads >= 1");
    return 1;
  }
  std::string error;
  if (!FLAGS_csv.empty() && !CheckOutputFile(FLAGS_csv, &error)) {
    PrintError("--csv: " + error);
    return 1;
  }
  std::vector<Row> rows;
  if (!FLAGS_lattice.empty()) {
    std::vector<int> cubes;
    bool whole = true;
    for (const std::string& s : SplitList(FLAGS_lattice)) {
      int n = 0;
      whole = whole && ParseInt(s, &n);
      cubes.push_back(n);
    }
    if (!whole || cubes.size() != 3 || *std::min_element(cubes.begin(), cubes.end()) < 1) {
      PrintError("--lattice must be three positive cube counts, e.g. 40,4,4");
      return 1;
    }
    LatticeOptions lattice;
    lattice.nx = cubes[0], lattice.ny = cubes[1], lattice.nz = cubes[2];
    lattice.spacing = FLAGS_spacing;
    if (!lattice.Validate(&error)) {
      PrintError("--lattice, --spacing: " + error);
      return 1;
    }
    const double elements = 6.0 * cubes[0] * cubes[1] * cubes[2];
    if (EquilibriumSolverMemoryBytes(elements) > MaxMemoryBytes()) {
      PrintError("--lattice: " + FormatBytes(EquilibriumSolverMemoryBytes(elements)) +
                 " estimated for the solves of " +
                 std::to_string(static_cast<long long>(elements)) +
                 " elements, above --max_memory_gb");
      return 1;
    }
    if (!(FLAGS_curl >= 0.0 && FLAGS_curl < 1.0)) {
      PrintError("--curl must be in [0, 1) (the fibres contract by 1 - curl), is " +
                 std::to_string(FLAGS_curl));
      return 1;
    }
    TetMesh mesh;
    std::unique_ptr<ShapeTargetModel> physics;
    RunCase(BarCase(cubes, &mesh, &physics), methods, &rows);
  }
  if (!FLAGS_model.empty()) {
    ActiveModel model;
    if (!LoadModel(FLAGS_model, &model, &error)) {
      PrintError(error);
      return 1;
    }
    const ShapeTargetModel physics(model.mesh, model.mu);
    std::vector<Case> cases;
    for (const std::string& name : SplitList(FLAGS_poses)) {
      const int p = model.PoseIndex(name);
      if (p < 0) {
        PrintError("--poses: the model has no training pose '" + name + "'");
        return 1;
      }
      Case c;
      c.name = name;
      c.physics = &physics;
      c.rest = model.mesh.vertices;
      c.bc = PoseBoundaryConditions(model, p);
      if (FLAGS_springs) {
        c.name += "(springs)";
        c.actuation = IdentityActuations(model.mesh.num_tets());
        c.springs = std::make_shared<EmbeddedAttachments>(
            model.embedding, model.mesh.tets,
            AttachmentStiffness(model, FLAGS_attachment_stiffness), model.mesh.vertices);
        c.spring_targets = model.poses[p].surface;
      } else if (model.decoder) {
        DecoderWorkspace workspace;
        model.decoder->Decode(model.decoder_params.data(), model.latents.col(p), &c.actuation,
                              &workspace);
      } else if (model.poses[p].target.cols() == model.mesh.num_tets()) {
        c.actuation = model.poses[p].target;
        c.name += "(target)";
      } else {
        PrintError("pose '" + name + "' has neither a decoder nor a volumetric target");
        return 1;
      }
      cases.push_back(c);
    }
    for (const std::string& item : SplitList(FLAGS_latents)) {
      const size_t eq = item.find('=');
      if (eq == std::string::npos || !model.decoder) {
        PrintError("--latents takes NAME=FILE pairs and a trained model ('" + item + "')");
        return 1;
      }
      Case c;
      c.name = item.substr(0, eq);
      c.physics = &physics;
      c.rest = model.mesh.vertices;
      ModelPose pose;
      if (!ResolveModelPose(model, item.substr(eq + 1), "", &pose, &error)) {
        PrintError(error);
        return 1;
      }
      c.bc = ModelBoundaryConditions(model, pose.bones);
      DecoderWorkspace workspace;
      model.decoder->Decode(model.decoder_params.data(), pose.latent, &c.actuation, &workspace);
      cases.push_back(c);
    }
    for (const Case& c : cases) RunCase(c, methods, &rows);
  }
  if (!FLAGS_csv.empty()) {
    std::string csv =
        "case,elements,method,converged,factorizations,lbfgs_iterations,projected_steps,"
        "exact_steps,lm_iterations,seconds,factorization_seconds,seconds_per_factorization,"
        "difference_over_size\n";
    for (const Row& row : rows) {
      const QuasistaticSolveReport& r = row.report;
      char line[512];
      std::snprintf(line, sizeof(line), "%s,%d,%s,%d,%d,%d,%d,%d,%d,%.6f,%.6f,%.3f,%.3e\n",
                    row.name.c_str(), row.elements, row.method.c_str(), r.converged ? 1 : 0,
                    r.factorizations, r.lbfgs_iterations, r.projected_steps, r.exact_steps,
                    r.lm_iterations, r.seconds, row.unit, row.unit > 0 ? r.seconds / row.unit : 0.0,
                    row.difference);
      csv += line;
    }
    if (!WriteFileAtomically(FLAGS_csv, csv, &error)) {
      PrintError(error);
      return 1;
    }
  }
  return 0;
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
