// Embeds ActiveQS as a solver component: a bar with one end fixed, a contracting
// actuation, the equilibrium, and the gradient of a loss with respect to the actuation.
#include <cstdio>
#include <string>

#include <activeqs/diff/equilibrium_differentiator.h>
#include <activeqs/equilibrium/quasistatic_solver.h>
#include <activeqs/mesh/lattice.h>
#include <activeqs/physics/actuation_fields.h>

int main() {
  aqs::LatticeOptions lattice;
  lattice.nx = 8;
  lattice.ny = lattice.nz = 2;
  lattice.spacing = 0.25;
  const aqs::TetMesh mesh = aqs::MakeLatticeMesh(lattice);
  aqs::BoundaryConditions bc;
  for (int v = 0; v < mesh.num_vertices(); ++v) {
    if (mesh.vertices(0, v) == 0.0) bc.vertices.push_back(v);
  }
  const aqs::ShapeTargetModel model(mesh, 1.0);
  aqs::QuasistaticSolver solver(model, bc);
  solver.actuation() = aqs::SmoothFibreActuation(mesh, 0.2);
  const aqs::QuasistaticSolveReport report = solver.Solve();
  std::printf("%s\n", report.Summary().c_str());
  if (!report.converged) return 1;
  aqs::EquilibriumDifferentiator differentiator(solver.stiffness_factorization());
  std::string error;
  if (!differentiator.Prepare(solver.positions(), solver.actuation(), &error)) {
    std::printf("%s\n", error.c_str());
    return 1;
  }
  const Eigen::Matrix3Xd x = solver.positions();
  const aqs::ActuationMatrix gradient = differentiator.LossGradient(x - mesh.vertices);
  // The verdict comes before the line the test looks for, so a NaN or zero gradient
  // never prints it.
  const bool ok = gradient.allFinite() && gradient.norm() > 0;
  std::printf("%s: %d elements, |dL/da| = %g\n", ok ? "consumer ok" : "consumer FAILED",
              model.num_elements(), gradient.norm());
  return ok ? 0 : 1;
}
