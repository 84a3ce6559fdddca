#include "equilibrium/preconditioned_lbfgs.h"

#include <cmath>
#include <deque>
#include <sstream>
#include <string>

#include <glog/logging.h>

namespace aqs {
namespace {


// One correction pair (free-DOF vectors): s = x_{k+1} - x_k, y = g_{k+1} - g_k.
struct Correction {
  Eigen::VectorXd s, y;
  double rho;  // 1 / (s . y)
};

// The L-BFGS two-loop recursion with initial inverse Hessian M^-1: H g.
Eigen::VectorXd ApplyInverseHessian(const std::deque<Correction>& pairs, Eigen::VectorXd q,
                                    StiffnessFactorization* preconditioner) {
  std::vector<double> alpha(pairs.size());
  for (int i = static_cast<int>(pairs.size()) - 1; i >= 0; --i) {
    alpha[i] = pairs[i].rho * pairs[i].s.dot(q);
    q -= alpha[i] * pairs[i].y;
  }
  Eigen::VectorXd r = preconditioner->SolveFree(q);
  for (size_t i = 0; i < pairs.size(); ++i) {
    const double beta = pairs[i].rho * pairs[i].y.dot(r);
    r += (alpha[i] - beta) * pairs[i].s;
  }
  return r;
}

}  // namespace

bool PreconditionedLbfgsOptions::Validate(std::string* error) const {
  std::ostringstream out;
  if (!(force_tolerance >= 0.0) || !std::isfinite(force_tolerance)) {
    out << "force_tolerance must be finite and >= 0 (is " << force_tolerance << ")";
  } else if (max_iterations < 0) {
    out << "max_iterations must be >= 0 (is " << max_iterations << ")";
  } else if (memory < 0 || memory > 1000) {
    out << "memory must be in [0, 1000] (is " << memory << ")";
  } else if (stall_iterations < 0) {
    out << "stall_iterations must be >= 0 (is " << stall_iterations << ")";
  } else if (!(stall_reduction > 0.0 && stall_reduction < 1.0)) {
    out << "stall_reduction must be in (0, 1) (is " << stall_reduction << ")";
  }
  *error = out.str();
  return error->empty() && line_search.Validate(error);
}

PreconditionedLbfgsReport MinimizeEnergyLbfgs(const PreconditionedLbfgsOptions& options,
                                              const ShapeTargetModel::ActuationRef& a,
                                              StiffnessFactorization* preconditioner,
                                              Eigen::Matrix3Xd* x) {
  CHECK(preconditioner->factorized()) << "factorize the preconditioner first";
  // The solver builds the options from validated QuasistaticSolverOptions.
  std::string invalid;
  CHECK(options.Validate(&invalid)) << "PreconditionedLbfgsOptions: " << invalid;
  PreconditionedLbfgsReport report;
  const StiffnessPattern& pattern = preconditioner->pattern();
  Eigen::Matrix3Xd gradient, trial_gradient, trial;
  double energy = preconditioner->EnergyAndGradient(*x, a, &gradient);
  double force = MaxFreeVertexNorm(pattern, gradient);
  report.initial_energy = energy;
  report.initial_max_force = force;
  std::deque<Correction> pairs;
  Eigen::VectorXd g = preconditioner->GatherFree(gradient);
  std::ostringstream message;
  double mark_force = force;  // the stall test's reference (see stall_iterations)
  int mark_iteration = 0;
  while (true) {
    if (MinimizerShouldStop(energy, force, options.force_tolerance, report.iterations,
                            options.max_iterations, "iteration", &message, &report.converged)) {
      break;
    }
    if (force <= options.stall_reduction * mark_force) {
      mark_force = force;
      mark_iteration = report.iterations;
    } else if (options.stall_iterations > 0 &&
               report.iterations - mark_iteration >= options.stall_iterations) {
      report.stalled = true;
      message << "stalled: the largest force " << force << " is above "
              << options.stall_reduction << " x " << mark_force << " after "
              << report.iterations - mark_iteration << " iterations";
      break;
    }
    Eigen::VectorXd direction = -ApplyInverseHessian(pairs, g, preconditioner);
    double slope = g.dot(direction);
    if (!(slope < 0.0) && !pairs.empty()) {  // not a descent direction: forget the pairs
      pairs.clear();
      ++report.memory_resets;
      direction = -ApplyInverseHessian(pairs, g, preconditioner);
      slope = g.dot(direction);
    }
    if (!(slope < 0.0)) {
      message << "the preconditioned gradient is not a descent direction";
      break;
    }
    const Eigen::Matrix3Xd step = preconditioner->ScatterFree(direction.data());
    bool accepted = false;
    double t = 1.0, trial_energy = 0.0;
    for (int halving = 0; halving <= options.line_search.max_halvings; ++halving, t *= 0.5) {
      trial = *x + t * step;
      trial_energy = preconditioner->EnergyAndGradient(trial, a, &trial_gradient);
      ++report.energy_evaluations;
      if (std::isfinite(trial_energy) && options.line_search.SufficientDecrease(energy, trial_energy, t, slope)) {
        accepted = true;
        break;
      }
    }
    if (!accepted) {
      if (!pairs.empty()) {  // retry from the preconditioned gradient
        pairs.clear();
        ++report.memory_resets;
        continue;
      }
      message << "the line search found no decrease of the energy at largest force " << force;
      break;
    }
    const Eigen::VectorXd trial_g = preconditioner->GatherFree(trial_gradient);
    Correction pair{t * direction, trial_g - g, 0.0};
    const double sy = pair.s.dot(pair.y);
    // Keep only pairs of positive curvature (the energy is not convex).
    if (!(sy > 1e-12 * pair.s.norm() * pair.y.norm())) {
      ++report.skipped_pairs;
    } else if (options.memory > 0) {
      pair.rho = 1.0 / sy;
      pairs.push_back(std::move(pair));
      if (static_cast<int>(pairs.size()) > options.memory) pairs.pop_front();
    }
    x->swap(trial);
    gradient.swap(trial_gradient);
    g = trial_g;
    energy = trial_energy;
    force = MaxFreeVertexNorm(pattern, gradient);
    ++report.iterations;
  }
  report.final_energy = energy;
  report.final_max_force = force;
  report.message = message.str();
  return report;
}

}  // namespace aqs
