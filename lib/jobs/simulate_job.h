#ifndef AQS_JOBS_SIMULATE_JOB_H_
#define AQS_JOBS_SIMULATE_JOB_H_

#include <ostream>
#include <string>
#include <vector>

#include "diff/equilibrium_differentiator.h"
#include "equilibrium/quasistatic_solver.h"
#include "util/job_status.h"
#include "util/memory_limit.h"

namespace aqs {

// What aqs_simulate does, as a library call: read a tet mesh, boundary conditions and
// actuation, solve the equilibrium, write the result, and optionally evaluate a loss
// against a target state and its gradient with respect to the actuation.
struct SimulateJobOptions {
  // Model mode: with `model` (a trained model directory), the actuation is decoded from
  // a latent (`latent`: a latent file, io/latent_io.h, or `pose`: a training pose's
  // latent and bone motion) and the model's own mesh, material and boundary conditions
  // are used; .obj outputs are then the model's surface (the neutral's faces). The
  // mesh/fixed/actuation/mu/loss options below are for plain meshes and must be empty.
  std::string model;
  std::string latent;
  std::string pose;
  // With --pose: start from the rest shape instead of the pose's stored training
  // equilibrium.
  bool from_rest = false;
  std::string mesh;            // tet mesh (.mesh, .node/.ele, .msh); required without model
  std::string fixed;           // fixed-vertex file (io/vertex_list_io.h); empty: none
  std::string actuation;       // actuation file (io/actuation_io.h); empty: S = I
  double mu = 1.0;             // stiffness of every element (> 0)
  std::string mu_per_element;  // one mu per line; overrides `mu` when set
  std::string initial;         // warm start: a tet-mesh file with the same vertex count
  std::vector<std::string> outputs;  // .mesh / .vtu / .obj (at least one)
  // Loss L = 1/2 sum_v |x_v - y_v|^2 over all vertices, y read from this tet-mesh file
  // (same vertex count; its elements are not used).
  std::string loss_target;
  std::string gradient;        // where to write dL/da (needs loss_target)
  QuasistaticSolverOptions solver;
  // Mesh mode: a mesh whose solve (EquilibriumSolverMemoryBytes; twice that with
  // `gradient`, whose adjoint factorizes the exact stiffness beside the solver's) would
  // need more is refused before it is allocated.
  double max_memory_bytes = kDefaultMaxMemoryBytes;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};


struct SimulateJobResult {
  JobStatus status = JobStatus::kOk;
  std::string message;  // what went wrong (empty when kOk)
  QuasistaticSolveReport solve;
  bool has_loss = false;
  double loss = 0.0;
};

// Runs the job; progress and results go to `log` (one line per step).
SimulateJobResult RunSimulateJob(const SimulateJobOptions& options, std::ostream& log);

}  // namespace aqs

#endif  // AQS_JOBS_SIMULATE_JOB_H_
