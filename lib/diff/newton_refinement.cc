#include "diff/newton_refinement.h"

#include <sstream>

#include <glog/logging.h>

namespace aqs {
namespace {

// Largest |dE/dx_v| over free vertices, and the gradient itself.
double MaxFreeForce(const ShapeTargetModel& model, const StiffnessPattern& pattern,
                    const Eigen::Matrix3Xd& x, const ActuationMatrix& a, int num_threads,
                    Eigen::Matrix3Xd* gradient) {
  model.EnergyAndGradient(x, a, gradient, num_threads);
  double max_force = 0.0;
  for (int f = 0; f < pattern.num_free_vertices(); ++f) {
    max_force = std::max(max_force, gradient->col(pattern.vertex_of_free(f)).norm());
  }
  return max_force;
}

}  // namespace

NewtonRefinementReport RefineEquilibrium(const NewtonRefinementOptions& options,
                                         const ActuationMatrix& a,
                                         EquilibriumDifferentiator* differentiator,
                                         Eigen::Matrix3Xd* x) {
  const ShapeTargetModel& model = differentiator->model();
  const StiffnessPattern& pattern = differentiator->pattern();
  const int threads = differentiator->options().num_threads;
  NewtonRefinementReport report;
  Eigen::Matrix3Xd gradient;
  double force = MaxFreeForce(model, pattern, *x, a, threads, &gradient);
  report.initial_max_force = force;
  while (force > options.force_tolerance && report.steps < options.max_steps) {
    std::string error;
    if (!differentiator->Prepare(*x, a, &error)) {
      report.message = error;
      break;
    }
    const Eigen::Matrix3Xd step = differentiator->SolveAdjoint(gradient);
    double t = 1.0;
    bool improved = false;
    for (int halving = 0; halving <= options.max_halvings; ++halving, t *= 0.5) {
      const Eigen::Matrix3Xd trial = *x - t * step;
      Eigen::Matrix3Xd trial_gradient;
      const double trial_force = MaxFreeForce(model, pattern, trial, a, threads, &trial_gradient);
      if (trial_force < force) {
        *x = trial;
        gradient = trial_gradient;
        force = trial_force;
        improved = true;
        break;
      }
    }
    ++report.steps;
    if (!improved) {
      std::ostringstream out;
      out << "the largest force stopped decreasing at " << force
          << " (round-off floor or outside Newton's basin)";
      report.message = out.str();
      break;
    }
  }
  report.final_max_force = force;
  report.converged = force <= options.force_tolerance;
  if (report.converged && report.message.empty()) report.message = "force tolerance reached";
  if (!report.converged && report.message.empty()) report.message = "step limit reached";
  return report;
}

}  // namespace aqs
