#include "equilibrium/negative_curvature.h"

#include <cmath>
#include <random>

#include <glog/logging.h>

namespace aqs {
namespace {

// Energies within this fraction of |E| of each other are equal up to round-off.
constexpr double kEnergyNoise = 1e-12;

// Power iteration stops early once the Rayleigh quotient is negative and changed by less
// than this fraction of itself in the last iteration.
constexpr double kCurvatureSettled = 1e-2;

}  // namespace

bool FindNegativeCurvature(const std::vector<double>& exact_values, int iterations,
                           StiffnessFactorization* factorization, Eigen::VectorXd* direction,
                           double* relative_curvature) {
  const StiffnessPattern& pattern = factorization->pattern();
  const int n = pattern.num_dofs();
  if (!factorization->cholesky().factorized() || n == 0) return false;
  const double scale = factorization->MeanAbsDiagonal(exact_values);
  if (!(scale > 0.0)) return false;
  std::mt19937 generator(12345u);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = uniform(generator);
  v.normalize();
  double curvature = 0.0;
  bool found = false;
  for (int k = 0; k < iterations; ++k) {
    const Eigen::VectorXd kv = factorization->MultiplyValues(exact_values, v);
    const double next = v.dot(kv) / scale;  // v has unit norm
    if (!std::isfinite(next)) return false;
    if (next < 0.0) {
      const bool settled = found && std::abs(next - curvature) <= kCurvatureSettled * std::abs(next);
      *direction = v;
      curvature = next;
      found = true;
      if (settled) break;
    }
    // v <- (I - P^-1 K) v, normalized.
    Eigen::VectorXd w = v - factorization->SolveFree(kv);
    const double norm = w.norm();
    if (!(norm > 0.0) || !std::isfinite(norm)) break;
    v = w / norm;
  }
  if (!found) return false;
  *relative_curvature = curvature;
  return true;
}

NegativeCurvatureStep StepAlongNegativeCurvature(const StiffnessFactorization& factorization,
                                                 const ShapeTargetModel::ActuationRef& a,
                                                 const Eigen::VectorXd& direction,
                                                 double first_length, int max_trials,
                                                 Eigen::Matrix3Xd* x, double* energy,
                                                 Eigen::Matrix3Xd* gradient) {
  NegativeCurvatureStep result;
  Eigen::Matrix3Xd d = factorization.ScatterFree(direction.data());
  if (gradient->cwiseProduct(d).sum() > 0.0) d = -d;
  const double largest = d.colwise().norm().maxCoeff();
  if (!(largest > 0.0) || !(first_length > 0.0)) return result;
  d /= largest;  // now the vertex it moves most moves by 1
  Eigen::Matrix3Xd trial, trial_gradient, best, best_gradient;
  double best_energy = *energy;
  double best_length = 0.0;
  double length = first_length;
  bool expanding = true;
  for (int t = 0; t < max_trials; ++t) {
    trial = *x + length * d;
    const double trial_energy = factorization.EnergyAndGradient(trial, a, &trial_gradient);
    ++result.energy_evaluations;
    const bool lower = std::isfinite(trial_energy) && trial_energy < best_energy;
    if (lower) {
      best_energy = trial_energy;
      best_length = length;
      best.swap(trial);
      best_gradient.swap(trial_gradient);
    }
    if (t == 0 && !lower) expanding = false;
    if (expanding) {
      if (!lower) break;  // past the lowest point along d
      length *= 2.0;
    } else {
      if (lower) break;
      length *= 0.5;
    }
  }
  if (best_length > 0.0 && *energy - best_energy > kEnergyNoise * std::abs(*energy)) {
    x->swap(best);
    gradient->swap(best_gradient);
    *energy = best_energy;
    result.accepted = true;
    result.length = best_length;
  }
  return result;
}

}  // namespace aqs
