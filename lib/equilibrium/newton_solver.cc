#include "equilibrium/newton_solver.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include <glog/logging.h>

#include "equilibrium/negative_curvature.h"

namespace aqs {
namespace {


// Relative diagonal shifts tried, in turn, when the projected stiffness is singular.
constexpr double kFirstShift = 1e-8;
constexpr double kShiftGrowth = 100.0;
constexpr double kLastShift = 1e4;

// Energies within this fraction of |E| of each other are equal up to round-off (the
// energy is a sum of num_elements non-negative terms, each exact to a few ulps).
constexpr double kEnergyNoise = 1e-12;

// After the exact stiffness is rejected at largest force f, exact steps are tried again
// once the force is below kExactRetryFraction f, or after kExactRetrySteps projected
// steps, whichever comes first (and never above exact_force_threshold). Projected steps
// near an equilibrium converge only linearly (a few percent per step on the 240K face's
// jawOpen, 17% on a buckled bar), while the exact K there turns positive definite within
// a few steps; a retry on a K that is still indefinite usually costs CG iterations only.
constexpr double kExactRetryFraction = 0.5;
constexpr int kExactRetrySteps = 4;

// Where the exact K is still indefinite on a retry, the next projected factor also
// serves a search for K's direction of most negative curvature (power iteration, at most
// kNegativeCurvatureIterations products and solves), and a step along it replaces the
// projected step: the first trial moves the vertex it moves most by
// kNegativeCurvatureFirstLength element sizes, then lengths double while the energy falls
// (at most kNegativeCurvatureTrials energy evaluations). Near a saddle (the energy flat,
// the force near zero) projected steps leave it only by a small factor per step, and
// exact steps by CG on an earlier factor can converge to it (CG need not meet the
// negative curvature).
constexpr double kNegativeCurvatureFirstLength = 1e-2;

// The --v=3 trace of one Newton step: its kind, the energy (to 15 digits, since a stalled
// solve changes it in the 12th), the largest free-vertex force and the vertex that carries
// it (where a crawling solve is stuck), the accepted step length (0: rejected).
void LogStep(const StiffnessPattern& pattern, int step, const char* kind, double shift,
             double energy, const Eigen::Matrix3Xd& gradient, double length, int factorizations) {
  int worst = -1;
  double largest = -1.0;
  for (int f = 0; f < pattern.num_free_vertices(); ++f) {
    const double norm = gradient.col(pattern.vertex_of_free(f)).norm();
    if (norm > largest) largest = norm, worst = pattern.vertex_of_free(f);
  }
  std::ostringstream line;
  line << "Newton step " << step << " " << kind;
  if (shift > 0.0) line << " (shift " << shift << ")";
  line << ": energy " << std::setprecision(15) << energy << std::setprecision(6)
       << ", largest force " << largest << " at vertex " << worst << ", "
       << (length > 0.0 ? "step length " + std::to_string(length) : std::string("rejected"))
       << ", " << factorizations << " factorizations";
  VLOG(3) << line.str();
}

}  // namespace

bool NewtonSolverOptions::Validate(std::string* error) const {
  std::ostringstream out;
  if (!(force_tolerance >= 0.0) || !std::isfinite(force_tolerance)) {
    out << "force_tolerance must be finite and >= 0 (is " << force_tolerance << ")";
  } else if (!(exact_force_threshold >= 0.0)) {
    out << "exact_force_threshold must be >= 0 (is " << exact_force_threshold << ")";
  } else if (max_factorizations < 1) {
    out << "max_factorizations must be >= 1 (is " << max_factorizations << ")";
  }
  *error = out.str();
  return error->empty() && line_search.Validate(error);
}

NewtonSolveReport MinimizeEnergyNewton(const NewtonSolverOptions& options,
                                       const ShapeTargetModel::ActuationRef& a,
                                       StiffnessFactorization* factorization,
                                       Eigen::Matrix3Xd* x) {
  NewtonSolveReport report;
  const StiffnessPattern& pattern = factorization->pattern();
  Eigen::Matrix3Xd gradient, trial_gradient, trial;
  double energy = factorization->EnergyAndGradient(*x, a, &gradient);
  double force = MaxFreeVertexNorm(pattern, gradient);
  report.initial_energy = energy;
  report.initial_max_force = force;
  // Exact steps are tried while the force is at most this: the threshold, lowered to
  // kExactRetryFraction of the force of a state where the exact stiffness was rejected
  // (so that a region of indefinite K costs a few attempts, not one per step).
  double exact_limit = options.exact_force_threshold;
  // The relative diagonal shift that last made the projected K factorizable (0: none).
  double last_shift = 0.0;
  bool projected_here = false;  // the exact K was rejected at the current x
  int projected_since_rejection = 0;  // accepted projected steps since the last rejection
  bool no_reuse_here = false;   // a step by CG on an earlier factor failed at the current x
  // The exact K of the current x, kept when it was rejected on a retry: the next
  // projected factor then serves a search for its negative curvature.
  std::vector<double> indefinite_values;
  std::ostringstream message;
  while (true) {
    if (MinimizerShouldStop(energy, force, options.force_tolerance, report.factorizations,
                            options.max_factorizations, "factorization", &message,
                            &report.converged)) {
      break;
    }
    const bool exact = !projected_here &&
                       (force <= exact_limit ||
                        (projected_since_rejection >= kExactRetrySteps &&
                         force <= options.exact_force_threshold));
    std::string error;
    Eigen::Matrix3Xd step;
    bool reused = false;
    if (exact) {
      factorization->Assemble(*x, a, StiffnessKind::kExact);
      // An inexact Newton step by CG on the factor of an earlier state, if it converges.
      Eigen::MatrixXd free_step;
      if (!no_reuse_here &&
          factorization->SolveReusingFactor(factorization->GatherFree(gradient), options.reuse,
                                            &free_step)) {
        reused = true;
        step = -factorization->ScatterFree(free_step.data());
      } else {
        // CG met non-positive curvature: K is not positive definite, and its
        // factorization would fail. Reject it without paying for that.
        const bool indefinite = factorization->last_reuse_found_indefinite();
        if (!indefinite) ++report.factorizations;
        if (indefinite || !factorization->FactorizeAssembled(0.0, &error)) {
          VLOG(3) << "Newton: the exact stiffness at largest force " << force << " is not "
                  << "positive definite";
          if (indefinite) {
            VLOG(3) << "Newton: found by CG, along a direction of relative curvature "
                    << factorization->last_reuse_relative_curvature();
          }
          // Still indefinite on a retry: the next projected factor serves a search for
          // the negative curvature of this K.
          if (report.exact_rejections > 0 && options.negative_curvature_steps) {
            indefinite_values = factorization->values();
          }
          VLOG(3) << "Newton: projected steps until the force is below "
                  << std::min(exact_limit, kExactRetryFraction * force) << " or for "
                  << kExactRetrySteps << " steps";
          ++report.exact_rejections;
          projected_since_rejection = 0;
          projected_here = true;
          exact_limit = std::min(exact_limit, kExactRetryFraction * force);
          continue;
        }
      }
    } else {
      factorization->Assemble(*x, a, StiffnessKind::kProjected);
      // Unshifted first, unless the last step needed a shift: then a tenth of it.
      double shift = last_shift > 0.0 ? last_shift / 10.0 : 0.0;
      bool factorized = false;
      while (!factorized && report.factorizations < options.max_factorizations) {
        ++report.factorizations;
        factorized = factorization->FactorizeAssembled(shift, &error);
        if (factorized) break;
        shift = shift == 0.0 ? kFirstShift : shift * kShiftGrowth;
        if (shift > kLastShift) break;
      }
      if (!factorized) {
        message << "the projected stiffness could not be factorized, even shifted: " << error;
        break;
      }
      if (shift > 0.0) ++report.shifted_factorizations;
      last_shift = shift;
      if (!indefinite_values.empty()) {
        std::vector<double> values;
        values.swap(indefinite_values);
        Eigen::VectorXd direction;
        double curvature = 0.0;
        if (FindNegativeCurvature(values, kNegativeCurvatureIterations, factorization,
                                  &direction, &curvature)) {
          const double before = energy;
          // A typical element size: the scale of the step.
          const ShapeTargetModel& model = factorization->model();
          const double element_size =
              std::cbrt(model.total_volume() / std::max(1, model.num_elements()));
          const NegativeCurvatureStep along = StepAlongNegativeCurvature(
              *factorization, a, direction, kNegativeCurvatureFirstLength * element_size,
              kNegativeCurvatureTrials, x, &energy, &gradient);
          report.energy_evaluations += along.energy_evaluations;
          if (VLOG_IS_ON(3)) {
            std::ostringstream line;
            line << "Newton: negative curvature " << curvature << " (relative to mean diag K); ";
            if (along.accepted) {
              line << "a step along it moved a vertex by " << along.length << ", energy "
                   << std::setprecision(15) << before << " -> " << energy;
            } else {
              line << "no step along it lowered the energy";
            }
            VLOG(3) << line.str();
          }
          if (along.accepted) {
            ++report.negative_curvature_steps;
            force = MaxFreeVertexNorm(pattern, gradient);
            // Off the saddle: the exact K is worth trying again at the usual threshold.
            exact_limit = options.exact_force_threshold;
            projected_here = false;
            no_reuse_here = false;
            continue;
          }
        }
      }
    }
    if (!reused) step = -factorization->Solve(gradient);
    const double slope = gradient.cwiseProduct(step).sum();
    bool accepted = false;
    double accepted_length = 0.0;
    if (slope < 0.0 && std::isfinite(slope)) {
      double t = 1.0;
      for (int halving = 0; halving <= options.line_search.max_halvings; ++halving, t *= 0.5) {
        trial = *x + t * step;
        const double trial_energy = factorization->EnergyAndGradient(trial, a, &trial_gradient);
        ++report.energy_evaluations;
        if (!std::isfinite(trial_energy)) continue;
        const double trial_force = MaxFreeVertexNorm(pattern, trial_gradient);
        const bool sufficient = options.line_search.SufficientDecrease(energy, trial_energy, t, slope);
        // Below the energy's round-off the decrease test is noise: the force decides.
        const bool round_off = trial_energy - energy <= kEnergyNoise * std::abs(energy) &&
                               trial_force < force;
        if (sufficient || round_off) {
          x->swap(trial);
          gradient.swap(trial_gradient);
          energy = trial_energy;
          force = trial_force;
          accepted = true;
          accepted_length = t;
          break;
        }
      }
    }
    if (VLOG_IS_ON(3)) {
      LogStep(pattern, report.exact_steps + report.projected_steps,
              exact ? (reused ? "exact by CG" : "exact") : "projected", exact ? 0.0 : last_shift,
              energy, gradient, accepted_length, report.factorizations);
    }
    if (accepted) {
      ++(exact ? report.exact_steps : report.projected_steps);
      if (!exact) ++projected_since_rejection;
      if (reused) ++report.reused_steps;
      projected_here = false;
      no_reuse_here = false;
      continue;
    }
    if (reused) {  // the inexact step failed: an exact one from a fresh factorization
      no_reuse_here = true;
      continue;
    }
    if (exact) {  // an exact step that does not descend: a projected one from here
      ++report.exact_rejections;
      projected_since_rejection = 0;
      projected_here = true;
      exact_limit = std::min(exact_limit, kExactRetryFraction * force);
      continue;
    }
    message << "the line search found no decrease of the energy at largest force " << force
            << " (the round-off floor of the energy)";
    break;
  }
  report.final_energy = energy;
  report.final_max_force = force;
  report.message = message.str();
  return report;
}

}  // namespace aqs
