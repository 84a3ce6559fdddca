#include "equilibrium/negative_curvature.h"

#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>
#include <glog/logging.h>

namespace aqs {
namespace {

// Energies within this fraction of |E| of each other are equal up to round-off.
constexpr double kEnergyNoise = 1e-12;

// The search stops early once the Rayleigh quotient rho is negative and the residual
// |K x - rho x| is at most this fraction of |rho| (a change of the quotient by under 1% in
// one iteration is no such sign: with a preconditioner that misses part of K it moves in
// plateaus).
constexpr double kResidualSettled = 0.1;

// Quotients above -kMinCurvature (relative to the mean |diagonal|) are round-off of a
// singular, positive semi-definite K (a mode no element resists), not negative
// curvature.
constexpr double kMinCurvature = 1e-8;

// A new basis vector whose norm, after it is made orthogonal to the others, is below this
// fraction of its norm before is dropped (it adds nothing to the subspace).
constexpr double kDependent = 1e-10;

// Appends v to the orthonormal columns `basis` (Gram-Schmidt, twice for round-off) unless
// it is (nearly) in their span.
void AppendOrthonormal(const Eigen::VectorXd& v, std::vector<Eigen::VectorXd>* basis) {
  const double norm = v.norm();
  if (!(norm > 0.0) || !std::isfinite(norm)) return;
  Eigen::VectorXd u = v;
  for (int pass = 0; pass < 2; ++pass) {
    for (const Eigen::VectorXd& q : *basis) u -= q.dot(u) * q;
  }
  const double rest = u.norm();
  if (!(rest > kDependent * norm)) return;
  basis->push_back(u / rest);
}

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
  Eigen::VectorXd x(n);
  for (int i = 0; i < n; ++i) x[i] = uniform(generator);
  x.normalize();
  Eigen::VectorXd kx = factorization->MultiplyValues(exact_values, x);
  Eigen::VectorXd previous_step;  // p: the last change of x, orthogonal to the x before
  double curvature = 0.0;
  bool found = false;
  for (int k = 0; k < iterations; ++k) {
    const double rho = x.dot(kx);  // x has unit norm
    const double next = rho / scale;
    if (!std::isfinite(next)) break;  // keeps what was found before
    const Eigen::VectorXd residual = kx - rho * x;
    const double residual_norm = residual.norm();
    if (next < -kMinCurvature && next < curvature) {
      *direction = x;
      curvature = next;
      found = true;
      if (residual_norm <= kResidualSettled * std::abs(rho)) break;  // settled
    } else if (!found && std::abs(next) <= kMinCurvature &&
               residual_norm <= kResidualSettled * kMinCurvature * scale) {
      break;  // a null mode of a singular PSD K: round-off, which iterations do not lower
    }
    if (k + 1 == iterations) break;
    // Rayleigh-Ritz on span{x, P^-1 (K x - rho x), p}: the smallest eigenpair of K
    // restricted to it is the next x.
    std::vector<Eigen::VectorXd> basis = {x};
    AppendOrthonormal(factorization->SolveFree(residual), &basis);
    if (previous_step.size() == n) AppendOrthonormal(previous_step, &basis);
    const int m = static_cast<int>(basis.size());
    if (m == 1) break;  // the residual is (nearly) zero: x is an eigenvector
    std::vector<Eigen::VectorXd> k_basis = {kx};
    for (int j = 1; j < m; ++j) {
      k_basis.push_back(factorization->MultiplyValues(exact_values, basis[j]));
    }
    Eigen::MatrixXd restricted(m, m);
    for (int i = 0; i < m; ++i) {
      for (int j = i; j < m; ++j) {
        restricted(i, j) = restricted(j, i) = 0.5 * (basis[i].dot(k_basis[j]) +
                                                     basis[j].dot(k_basis[i]));
      }
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(restricted);
    if (eigen.info() != Eigen::Success) break;
    const Eigen::VectorXd c = eigen.eigenvectors().col(0);
    Eigen::VectorXd next_x = Eigen::VectorXd::Zero(n), next_kx = Eigen::VectorXd::Zero(n);
    for (int j = 0; j < m; ++j) {
      next_x += c[j] * basis[j];
      next_kx += c[j] * k_basis[j];
    }
    const double norm = next_x.norm();
    if (!(norm > 0.0) || !std::isfinite(norm)) break;
    next_x /= norm;
    next_kx /= norm;
    previous_step = next_x - x.dot(next_x) * x;
    x = next_x;
    kx = next_kx;
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
