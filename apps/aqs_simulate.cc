// aqs_simulate: the quasistatic equilibrium of a shape-targeting tet mesh for a given
// actuation, written as .mesh / .vtu / .obj; optionally a loss against a target state
// and its gradient with respect to every element's actuation.
//
// Exit status: 0 done; 1 bad input or unwritable output; 2 the equilibrium was not
// reached (outputs are written anyway, for inspection); 3 no gradient (K is not
// positive definite at the solution).

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/simulate_job.h"

DEFINE_string(mesh, "", "Tet mesh: .mesh (MEDIT), .node/.ele (TetGen) or .msh (Gmsh 2.2/4.1 ASCII).");
DECLARE_string(model);
DEFINE_string(latent, "", "With --model: a latent file (as aqs_fit writes) to decode and simulate.");
DEFINE_string(pose, "", "With --model: simulate this training pose (its latent and bone motion).");
DEFINE_bool(from_rest, false, "With --pose: solve from the rest shape, not from the pose's stored "
            "training equilibrium.");
DEFINE_string(fixed, "", "Fixed vertices: one per line, 'i' (at rest) or 'i x y z' (prescribed).");
DEFINE_string(actuation, "", "Actuation: one line per element, 'sxx syy szz sxy sxz syz'. "
              "Default: S = I everywhere.");
DEFINE_double(mu, 1.0, "Stiffness mu of every element (> 0).");
DEFINE_string(mu_per_element, "", "Optional file with one mu per element (overrides --mu).");
DEFINE_string(initial, "", "Optional warm start: a tet-mesh file with the same vertices.");
DEFINE_string(output, "", "Output file(s), comma-separated: .mesh (deformed tet mesh), "
              ".vtu (ParaView, with fields), .obj (boundary surface).");
DEFINE_string(loss_target, "", "Target state (tet-mesh file, same vertex count) for the loss "
              "L = 1/2 sum_v |x_v - y_v|^2.");
DEFINE_string(gradient, "", "Where to write dL/da (one line per element); needs --loss_target.");
DEFINE_double(tolerance, 1e-6, "Relative force tolerance: max free-vertex force <= tolerance "
              "x (force of an element under unit strain). Down to ~1e-13 is reachable.");
DEFINE_int32(max_iterations, 200, "Iterations at most: stiffness factorizations (--solver=newton) "
             "or Ceres iterations plus factorizations (--solver=lm).");
DECLARE_int32(threads);
DEFINE_double(newton_relative_force, 1e-2, "Steps use the exact stiffness once the relative force "
              "is below this (--solver=newton: projected stiffness above it, 0: projected only; "
              "--solver=lm: Ceres above it, 0: Ceres only).");
DEFINE_bool(ensure_stable, true, "Check that the equilibrium reached is stable (one factorization "
            "of the exact stiffness there) and leave it if it is a saddle (at most 3 times).");
DEFINE_bool(verbose, false, "Print Ceres' per-iteration progress.");

int main(int argc, char** argv) {
  aqs::InitApp(
      "Solve the quasistatic equilibrium of a shape-targeting tet mesh.\n"
      "  aqs_simulate --mesh=M.mesh --fixed=F.txt [--actuation=A.txt] [--mu=1] --output=OUT.vtu\n"
      "               [--loss_target=Y.mesh --gradient=G.txt]\n"
      "  aqs_simulate --model=MODEL (--latent=Z.txt | --pose=NAME) --output=OUT.obj,OUT.vtu",
      &argc, &argv);
  aqs::SimulateJobOptions options;
  options.model = FLAGS_model;
  options.latent = FLAGS_latent;
  options.pose = FLAGS_pose;
  options.from_rest = FLAGS_from_rest;
  options.mesh = FLAGS_mesh;
  options.fixed = FLAGS_fixed;
  options.actuation = FLAGS_actuation;
  options.mu = FLAGS_mu;
  options.mu_per_element = FLAGS_mu_per_element;
  options.initial = FLAGS_initial;
  options.outputs = aqs::SplitList(FLAGS_output);
  options.loss_target = FLAGS_loss_target;
  options.gradient = FLAGS_gradient;
  options.max_memory_bytes = aqs::MaxMemoryBytes();
  options.solver.relative_force_tolerance = FLAGS_tolerance;
  options.solver.max_iterations = FLAGS_max_iterations;
  options.solver.num_threads = FLAGS_threads;
  options.solver.log_progress = FLAGS_verbose;
  options.solver.newton_relative_force = FLAGS_newton_relative_force;
  options.solver.ensure_stable = FLAGS_ensure_stable;
  std::string error;
  if (!aqs::SolverMethodFromFlag(&options.solver, &error)) {
    aqs::PrintError(error);
    return 1;
  }
  if (!FLAGS_model.empty() && !gflags::GetCommandLineFlagInfoOrDie("mu").is_default) {
    // Not refused: a flagfile shared with aqs_prepare may set it.
    std::cout << "note: --mu is not used with --model (the model's own stiffness, mu.bin, "
                 "is)\n";
  }
  aqs::FlagNames flags = aqs::CommonFlagNames();
  flags.insert(flags.end(), {{"mu", "--mu"},
                             {"solver.relative_force_tolerance", "--tolerance"},
                             {"solver.max_iterations", "--max_iterations"},
                             {"solver.newton_relative_force", "--newton_relative_force"}});
  const aqs::SimulateJobResult result = aqs::RunSimulateJob(options, std::cout);
  return aqs::FinishJob(result.status, result.message, flags);
}
