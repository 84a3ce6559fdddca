#include "equilibrium/newton_refinement.h"

#include <sstream>

namespace aqs {
namespace {

// Largest |dE/dx_v| over free vertices; also returns the gradient and energy.
double MaxFreeForce(const StiffnessFactorization& factorization, const Eigen::Matrix3Xd& x,
                    const ShapeTargetModel::ActuationRef& a, Eigen::Matrix3Xd* gradient,
                    double* energy) {
  *energy = factorization.EnergyAndGradient(x, a, gradient);
  const StiffnessPattern& pattern = factorization.pattern();
  double max_force = 0.0;
  for (int f = 0; f < pattern.num_free_vertices(); ++f) {
    max_force = std::max(max_force, gradient->col(pattern.vertex_of_free(f)).norm());
  }
  return max_force;
}

}  // namespace

NewtonRefinementReport RefineEquilibrium(const NewtonRefinementOptions& options,
                                         const ShapeTargetModel::ActuationRef& a,
                                         StiffnessFactorization* factorization,
                                         Eigen::Matrix3Xd* x) {
  NewtonRefinementReport report;
  Eigen::Matrix3Xd gradient;
  double energy = 0.0;
  double force = MaxFreeForce(*factorization, *x, a, &gradient, &energy);
  report.initial_max_force = force;
  while (force > options.force_tolerance && report.steps < options.max_steps) {
    std::string error;
    ++report.steps;
    if (!factorization->Factorize(*x, a, StiffnessKind::kExact, &error)) {
      report.message = error;
      break;
    }
    const Eigen::Matrix3Xd step = factorization->Solve(gradient);
    double t = 1.0;
    bool improved = false;
    for (int halving = 0; halving <= options.max_halvings; ++halving, t *= 0.5) {
      const Eigen::Matrix3Xd trial = *x - t * step;
      Eigen::Matrix3Xd trial_gradient;
      double trial_energy = 0.0;
      const double trial_force =
          MaxFreeForce(*factorization, trial, a, &trial_gradient, &trial_energy);
      if (trial_force < force) {
        *x = trial;
        gradient = trial_gradient;
        force = trial_force;
        energy = trial_energy;
        improved = true;
        break;
      }
    }
    if (!improved) {
      std::ostringstream out;
      out << "the largest force stopped decreasing at " << force
          << " (round-off floor, or outside Newton's basin)";
      report.message = out.str();
      break;
    }
  }
  report.final_max_force = force;
  report.final_energy = energy;
  report.converged = force <= options.force_tolerance;
  if (report.message.empty()) {
    report.message = report.converged ? "force tolerance reached" : "step limit reached";
  }
  return report;
}

}  // namespace aqs
