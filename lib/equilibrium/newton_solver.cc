#include "equilibrium/newton_solver.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include <glog/logging.h>

#include "equilibrium/energy_term.h"
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
// serves a search for K's direction of most negative curvature (preconditioned by it, at
// most kNegativeCurvatureIterations solves), and a step along it replaces the
// projected step: the first trial moves the vertex it moves most by
// kNegativeCurvatureFirstLength element sizes, then lengths double while the energy falls
// (at most kNegativeCurvatureTrials energy evaluations). Near a saddle (the energy flat,
// the force near zero) projected steps leave it only by a small factor per step, and
// exact steps by CG on an earlier factor can converge to it (CG need not meet the
// negative curvature).
constexpr double kNegativeCurvatureFirstLength = 1e-2;

// The stall rule's progress (NewtonSolverOptions::stall_steps): the energy below its value
// at the last progress by more than kStallEnergy of it, or the largest force below
// kStallForce of its value then. Measured on the demo's jawOpen+mouthClose contact path
// (2026-12-06): one solve took 197 exact steps of length 1e-4 to 1e-7, the energy changing
// in its 12th digit and the largest force alternating between 0.0029 and 0.0038 at one
// vertex, until its 200 factorizations were spent (102 s).
constexpr double kStallEnergy = 1e-10;
constexpr double kStallForce = 0.9;

// The free vertex whose column of `gradient` (3 x num_vertices) is longest (-1 if none is
// free): where the largest force acts.
int LargestForceVertex(const StiffnessPattern& pattern, const Eigen::Matrix3Xd& gradient) {
  int worst = -1;
  double largest = -1.0;
  for (int f = 0; f < pattern.num_free_vertices(); ++f) {
    const double norm = gradient.col(pattern.vertex_of_free(f)).norm();
    if (norm > largest) largest = norm, worst = pattern.vertex_of_free(f);
  }
  return worst;
}

// The --v=3 trace of one Newton step: its kind, the energy (to 15 digits, since a stalled
// solve changes it in the 12th), the largest free-vertex force and the vertex that carries
// it (where a crawling solve is stuck), the accepted step length (0: rejected).
void LogStep(const StiffnessPattern& pattern, int step, const char* kind, double shift,
             double energy, const Eigen::Matrix3Xd& gradient, double length, int factorizations) {
  const int worst = LargestForceVertex(pattern, gradient);
  const double largest = worst < 0 ? 0.0 : gradient.col(worst).norm();
  std::ostringstream line;
  line << "Newton step " << step << " " << kind;
  if (shift > 0.0) line << " (shift " << shift << ")";
  line << ": energy " << std::setprecision(15) << energy << std::setprecision(6)
       << ", largest force " << largest << " at vertex " << worst << ", "
       << (length > 0.0 ? "step length " + std::to_string(length) : std::string("rejected"))
       << ", " << factorizations << " factorizations";
  VLOG(3) << line.str();
}

// One minimization by MinimizeEnergyNewton: its state between steps and its steps.
class NewtonMinimizer {
 public:
  NewtonMinimizer(const NewtonSolverOptions& options, const ShapeTargetModel::ActuationRef& a,
                  StiffnessFactorization* factorization, Eigen::Matrix3Xd* x)
      : options_(options),
        a_(a),
        factorization_(factorization),
        pattern_(factorization->pattern()),
        x_(x),
        exact_limit_(options.exact_force_threshold) {
    energy_ = factorization_->EnergyAndGradient(*x_, a_, &gradient_);
    force_ = MaxFreeVertexNorm(pattern_, gradient_);
    report_.initial_energy = energy_;
    report_.initial_max_force = force_;
    StartStallWindow();
  }

  NewtonSolveReport Run() {
    while (!MinimizerShouldStop(energy_, force_, options_.force_tolerance,
                                report_.factorizations, options_.max_factorizations,
                                "factorization", &message_, &report_.converged)) {
      const bool exact = ExactIsDue();
      Eigen::Matrix3Xd step;
      bool reused = false;
      if (exact) {
        if (!ExactStep(&step, &reused)) continue;  // rejected: projected steps from here
      } else {
        if (!FactorizeProjected()) break;
        if (StepAlongStoredNegativeCurvature()) {
          // Judged by what it lowered only: at a kink whose exact K is indefinite, steps
          // along negative curvature that lower the energy by round-off must not keep
          // the solve from stopping.
          if (Stalled(0.0)) break;
          continue;
        }
      }
      if (!reused) step = -factorization_->Solve(gradient_);
      double length = 0.0;
      const bool accepted = LineSearch(step, &length);
      if (VLOG_IS_ON(3)) {
        LogStep(pattern_, report_.exact_steps + report_.projected_steps,
                exact ? (reused ? "exact by CG" : "exact") : "projected",
                exact ? 0.0 : last_shift_, energy_, gradient_, length, report_.factorizations);
      }
      if (accepted) {
        ++(exact ? report_.exact_steps : report_.projected_steps);
        if (!exact) ++projected_since_rejection_;
        if (reused) ++report_.reused_steps;
        projected_here_ = false;
        no_reuse_here_ = false;
        if (Stalled(length)) break;
        if (!exact && options_.hand_back_after_projected_steps > 0 &&
            report_.projected_steps >= options_.hand_back_after_projected_steps &&
            force_ > options_.force_tolerance) {
          report_.handed_back = true;
          message_ << "handed back after " << report_.projected_steps
                   << " projected steps at largest force " << force_;
          break;
        }
        continue;
      }
      if (reused) {  // the inexact step failed: an exact one from a fresh factorization
        no_reuse_here_ = true;
        continue;
      }
      if (exact) {  // an exact step that does not descend: a projected one from here
        RejectExact();
        continue;
      }
      message_ << "the line search found no decrease of the energy at largest force " << force_
               << " (the round-off floor of the energy)";
      break;
    }
    report_.final_energy = energy_;
    report_.final_max_force = force_;
    report_.message = message_.str();
    return report_;
  }

 private:
  // Whether this step is tried on the exact stiffness: not where it was just rejected;
  // while the force is at most exact_limit_, or after kExactRetrySteps projected steps
  // below the threshold.
  bool ExactIsDue() const {
    return !projected_here_ &&
           (force_ <= exact_limit_ || (projected_since_rejection_ >= kExactRetrySteps &&
                                       force_ <= options_.exact_force_threshold));
  }

  // The exact K at x was rejected (not positive definite, or its step failed):
  // projected steps from here until the force has fallen to kExactRetryFraction of this
  // one, or for kExactRetrySteps steps.
  void RejectExact() {
    ++report_.exact_rejections;
    projected_since_rejection_ = 0;
    projected_here_ = true;
    exact_limit_ = std::min(exact_limit_, kExactRetryFraction * force_);
  }

  // Assembles the exact K at x and the Newton step on it (*step): an inexact one by CG
  // on the factor of an earlier state (*reused), or else from K's own factorization.
  // False if K is not positive definite (found by CG or by CHOLMOD): rejected.
  bool ExactStep(Eigen::Matrix3Xd* step, bool* reused) {
    factorization_->Assemble(*x_, a_, StiffnessKind::kExact);
    Eigen::MatrixXd free_step;
    // Steps by CG have a budget of their own (max_reused_steps): they cost no
    // factorization, and at the energy's round-off floor they can be accepted forever.
    const bool try_reuse = !no_reuse_here_ && reuse_attempts_ < options_.max_reused_steps;
    if (try_reuse) ++reuse_attempts_;
    if (try_reuse &&
        factorization_->SolveReusingFactor(factorization_->GatherFree(gradient_),
                                           options_.reuse, &free_step)) {
      *reused = true;
      *step = -factorization_->ScatterFree(free_step.data());
      return true;
    }
    // CG met non-positive curvature: K is not positive definite, and its factorization
    // would fail. Reject it without paying for that.
    const bool indefinite = try_reuse && factorization_->last_reuse_found_indefinite();
    if (!indefinite) ++report_.factorizations;
    std::string error;
    if (!indefinite && factorization_->FactorizeAssembled(0.0, &error)) return true;
    VLOG(3) << "Newton: the exact stiffness at largest force " << force_ << " is not "
            << "positive definite";
    if (indefinite) {
      VLOG(3) << "Newton: found by CG, along a direction of relative curvature "
              << factorization_->last_reuse_relative_curvature();
    }
    // Still indefinite on a retry: the next projected factor serves a search for the
    // negative curvature of this K.
    if (report_.exact_rejections > 0 && options_.negative_curvature_steps) {
      indefinite_values_ = factorization_->values();
    }
    VLOG(3) << "Newton: projected steps until the force is below "
            << std::min(exact_limit_, kExactRetryFraction * force_) << " or for "
            << kExactRetrySteps << " steps";
    RejectExact();
    return false;
  }

  // The energy and force the next steps are measured against (Stalled).
  void StartStallWindow() {
    window_energy_ = energy_;
    window_force_ = force_;
    window_steps_ = 0;
  }

  // After an accepted step of length t (0 for a step along negative curvature, which only
  // its energy and force decide): true (with the message) if it is the
  // options_.stall_steps-th step without progress since the window began (see
  // NewtonSolverOptions::stall_steps); a step that makes progress starts a new window.
  bool Stalled(double t) {
    if (options_.stall_steps <= 0) return false;
    if (force_ <= options_.force_tolerance) return false;  // converged: the loop ends
    if (t >= 1.0 || window_energy_ - energy_ > kStallEnergy * std::abs(window_energy_) ||
        force_ < kStallForce * window_force_) {
      StartStallWindow();
      return false;
    }
    if (++window_steps_ < options_.stall_steps) return false;
    if (VLOG_IS_ON(2)) LogForceSplit();
    report_.stalled = true;
    message_ << "stalled at largest force " << force_ << ": " << options_.stall_steps
             << " shortened steps lowered the energy by at most " << kStallEnergy
             << " of itself and the largest force by at most " << (1.0 - kStallForce) * 100.0
             << "% (a kink of the energy: its gradient jumps)";
    return true;
  }

  // The --v=2 trace of a stall: the force (-dE/dx) on the vertex that carries the largest
  // one, split into the model's part and each energy term's (which terms act where a
  // stalled solve is stuck; not which of them jumps).
  void LogForceSplit() const {
    const int worst = LargestForceVertex(pattern_, gradient_);
    if (worst < 0) return;
    std::ostringstream line;
    line << "Newton: stalled with force " << -gradient_.col(worst).transpose() << " at vertex "
         << worst << "; of it";
    Eigen::Vector3d model_part = -gradient_.col(worst);
    const std::vector<const EnergyTerm*>& terms = factorization_->energy_terms();
    for (size_t i = 0; i < terms.size(); ++i) {
      Eigen::Matrix3Xd term_gradient = Eigen::Matrix3Xd::Zero(3, x_->cols());
      terms[i]->AddEnergyAndGradient(*x_, &term_gradient);
      model_part += term_gradient.col(worst);
      line << " energy term " << i << " " << -term_gradient.col(worst).transpose() << ",";
    }
    line << " the model " << model_part.transpose();
    VLOG(2) << line.str();
  }

  // Assembles and factorizes the projected K at x: unshifted first, unless the last
  // projected factor needed a shift (then a tenth of it), the shift growing until CHOLMOD
  // succeeds. False (with the message) if it cannot be factorized within kLastShift or
  // the factorization budget.
  bool FactorizeProjected() {
    factorization_->Assemble(*x_, a_, StiffnessKind::kProjected);
    double shift = last_shift_ > 0.0 ? last_shift_ / 10.0 : 0.0;
    bool factorized = false;
    std::string error;
    while (!factorized && report_.factorizations < options_.max_factorizations) {
      ++report_.factorizations;
      factorized = factorization_->FactorizeAssembled(shift, &error);
      if (factorized) break;
      shift = shift == 0.0 ? kFirstShift : shift * kShiftGrowth;
      if (shift > kLastShift) break;
    }
    if (!factorized) {
      message_ << "the projected stiffness could not be factorized, even shifted: " << error;
      return false;
    }
    if (shift > 0.0) ++report_.shifted_factorizations;
    last_shift_ = shift;
    return true;
  }

  // With an exact K stored by a rejected retry (indefinite_values_, used up here): its
  // direction of most negative curvature, found with the projected factor just made,
  // and a step along it that lowers the energy. True if such a step was taken (x,
  // gradient, energy and force updated; exact steps are due again at the usual
  // threshold).
  bool StepAlongStoredNegativeCurvature() {
    if (indefinite_values_.empty()) return false;
    std::vector<double> values;
    values.swap(indefinite_values_);
    Eigen::VectorXd direction;
    double curvature = 0.0;
    if (!FindNegativeCurvature(values, kNegativeCurvatureIterations, factorization_, &direction,
                               &curvature)) {
      VLOG(3) << "Newton: no negative curvature found in " << kNegativeCurvatureIterations
              << " iterations";
      return false;
    }
    const double before = energy_;
    // A typical element size: the scale of the step.
    const ShapeTargetModel& model = factorization_->model();
    const double element_size =
        std::cbrt(model.total_volume() / std::max(1, model.num_elements()));
    const NegativeCurvatureStep along = StepAlongNegativeCurvature(
        *factorization_, a_, direction, kNegativeCurvatureFirstLength * element_size,
        kNegativeCurvatureTrials, x_, &energy_, &gradient_);
    report_.energy_evaluations += along.energy_evaluations;
    if (VLOG_IS_ON(3)) {
      std::ostringstream line;
      line << "Newton: negative curvature " << curvature << " (relative to mean diag K); ";
      if (along.accepted) {
        line << "a step along it moved a vertex by " << along.length << ", energy "
             << std::setprecision(15) << before << " -> " << energy_;
      } else {
        line << "no step along it lowered the energy";
      }
      VLOG(3) << line.str();
    }
    if (!along.accepted) return false;
    ++report_.negative_curvature_steps;
    force_ = MaxFreeVertexNorm(pattern_, gradient_);
    // Off the saddle: the exact K is worth trying again at the usual threshold.
    exact_limit_ = options_.exact_force_threshold;
    projected_here_ = false;
    no_reuse_here_ = false;
    return true;
  }

  // Backtracking along `step` from x: t = 1, 1/2, ... until sufficient decrease, or
  // (below the energy's round-off) a smaller largest force. True if a trial was accepted
  // (x, gradient, energy and force are the trial's, *length its t); false if `step` does
  // not descend or no trial is accepted (*length 0).
  bool LineSearch(const Eigen::Matrix3Xd& step, double* length) {
    *length = 0.0;
    const double slope = gradient_.cwiseProduct(step).sum();
    if (!(slope < 0.0) || !std::isfinite(slope)) return false;
    double t = 1.0;
    for (int halving = 0; halving <= options_.line_search.max_halvings; ++halving, t *= 0.5) {
      trial_ = *x_ + t * step;
      const double trial_energy = factorization_->EnergyAndGradient(trial_, a_, &trial_gradient_);
      ++report_.energy_evaluations;
      if (!std::isfinite(trial_energy)) continue;
      const double trial_force = MaxFreeVertexNorm(pattern_, trial_gradient_);
      const bool sufficient =
          options_.line_search.SufficientDecrease(energy_, trial_energy, t, slope);
      // Below the energy's round-off the decrease test is noise: the force decides.
      const bool round_off = trial_energy - energy_ <= kEnergyNoise * std::abs(energy_) &&
                             trial_force < force_;
      if (sufficient || round_off) {
        x_->swap(trial_);
        gradient_.swap(trial_gradient_);
        energy_ = trial_energy;
        force_ = trial_force;
        *length = t;
        return true;
      }
    }
    return false;
  }

  const NewtonSolverOptions& options_;
  const ShapeTargetModel::ActuationRef& a_;
  StiffnessFactorization* factorization_;
  const StiffnessPattern& pattern_;
  Eigen::Matrix3Xd* x_;
  Eigen::Matrix3Xd gradient_, trial_gradient_, trial_;
  double energy_ = 0.0;
  double force_ = 0.0;  // the largest free-vertex force at x
  int reuse_attempts_ = 0;  // exact steps tried by CG on an earlier factor
  NewtonSolveReport report_;
  std::ostringstream message_;
  // Exact steps are tried while the force is at most this: the threshold, lowered to
  // kExactRetryFraction of the force of a state where the exact stiffness was rejected
  // (so that a region of indefinite K costs a few attempts, not one per step).
  double exact_limit_;
  // The relative diagonal shift that last made the projected K factorizable (0: none).
  double last_shift_ = 0.0;
  bool projected_here_ = false;        // the exact K was rejected at the current x
  int projected_since_rejection_ = 0;  // accepted projected steps since the last rejection
  bool no_reuse_here_ = false;  // a step by CG on an earlier factor failed at the current x
  // The exact K of the current x, kept when it was rejected on a retry: the next
  // projected factor then serves a search for its negative curvature.
  std::vector<double> indefinite_values_;
  // The stall window (Stalled): energy and largest force where it began, and the steps
  // taken in it without progress.
  double window_energy_ = 0.0;
  double window_force_ = 0.0;
  int window_steps_ = 0;
};

}  // namespace

bool NewtonSolverOptions::Validate(std::string* error) const {
  std::ostringstream out;
  if (!(force_tolerance >= 0.0) || !std::isfinite(force_tolerance)) {
    out << "force_tolerance must be finite and >= 0 (is " << force_tolerance << ")";
  } else if (!(exact_force_threshold >= 0.0)) {
    out << "exact_force_threshold must be >= 0 (is " << exact_force_threshold << ")";
  } else if (max_factorizations < 1) {
    out << "max_factorizations must be >= 1 (is " << max_factorizations << ")";
  } else if (max_reused_steps < 0) {
    out << "max_reused_steps must be >= 0 (is " << max_reused_steps << ")";
  } else if (stall_steps < 0) {
    out << "stall_steps must be >= 0 (is " << stall_steps << ")";
  } else if (hand_back_after_projected_steps < 0) {
    out << "hand_back_after_projected_steps must be >= 0 (is "
        << hand_back_after_projected_steps << ")";
  }
  *error = out.str();
  return error->empty() && line_search.Validate(error);
}

NewtonSolveReport MinimizeEnergyNewton(const NewtonSolverOptions& options,
                                       const ShapeTargetModel::ActuationRef& a,
                                       StiffnessFactorization* factorization,
                                       Eigen::Matrix3Xd* x) {
  std::string error;
  CHECK(options.Validate(&error)) << "NewtonSolverOptions: " << error;
  return NewtonMinimizer(options, a, factorization, x).Run();
}

}  // namespace aqs
