#ifndef AQS_EQUILIBRIUM_NEGATIVE_CURVATURE_H_
#define AQS_EQUILIBRIUM_NEGATIVE_CURVATURE_H_

#include <vector>

#include <Eigen/Core>

#include "equilibrium/stiffness_factorization.h"
#include "physics/shape_target_model.h"

namespace aqs {

// A direction of negative curvature of an indefinite stiffness, and a step along it: how
// the Newton solver leaves a saddle of the energy (a buckling bar held straight, a face
// whose exact stiffness stays indefinite however close the force gets to zero), where
// Newton steps on the exact K are drawn to the saddle and steps on the PSD-projected K
// leave it only by a small factor per step.

// Iterations of a negative-curvature search, and energy evaluations of the step
// along it, as the Newton solver uses them: from a first trial of 1e-2 element sizes,
// 8 trials double it up to 1.28 element sizes (or halve it down to 1e-4). A longer step
// along the direction, found only approximately at 30 iterations, can land where
// projected steps crawl: on the 240K face's mouthClose in training, an uncapped one
// (up to 2^29 times the first) took a solve from 10 factorizations to 23.
inline constexpr int kNegativeCurvatureIterations = 30;
inline constexpr int kNegativeCurvatureTrials = 8;

// Searches a direction d (free DOFs, unit 2-norm) along which K = `exact_values` (a copy
// of factorization->values() assembled with StiffnessKind::kExact at the current state)
// curves down, approximating K's smallest eigenvector by preconditioned Rayleigh-Ritz
// iteration (LOBPCG with one vector: each iteration minimizes the Rayleigh quotient
// x'Kx / x'x over span{x, P^-1 (K x - rho x), the last step}), from a fixed
// pseudo-random start, with the factor `factorization` holds as the preconditioner P (a
// PSD-projected or shifted stiffness of the same state). It stops once the quotient is
// negative and the residual |K x - rho x| is at most 0.1 |rho| (then some eigenvalue of
// K lies within 10% of rho), or after `iterations` iterations (each one solve with the
// held factor and at most two products with K). Unlike power iteration on I - P^-1 K, the
// search before 2026-12-06, it does not need P >= K: in contact solves P holds a pair's
// Gauss-Newton part only and K also its curvature term, which can exceed P and then
// dominated that iteration. Its target differs too: K's own most negative curvature,
// where power iteration's was the most negative relative to P. Returns true with
// *direction and *relative_curvature = d'Kd / mean|diag K| < -1e-8 (the lowest quotient
// met); false if no factor is held, K or a solve is not finite before one was met, or no
// quotient below -1e-8 (a singular PSD K's round-off) was met.
bool FindNegativeCurvature(const std::vector<double>& exact_values, int iterations,
                           StiffnessFactorization* factorization, Eigen::VectorXd* direction,
                           double* relative_curvature);

struct NegativeCurvatureStep {
  bool accepted = false;
  double length = 0.0;        // the largest vertex displacement of the accepted step
  int energy_evaluations = 0;
};

// A step along the free-DOF direction d (scattered to vertices, its sign chosen so that
// it does not ascend: dE/dx . d <= 0) by an expanding line search: the first trial moves
// the vertex that d moves most by first_length, and lengths double while the energy keeps
// falling (halve, if the first trial does not lower it), at most max_trials energy
// evaluations. On acceptance *x, *energy and *gradient are those of the lowest energy
// found (below *energy by more than its round-off).
NegativeCurvatureStep StepAlongNegativeCurvature(const StiffnessFactorization& factorization,
                                                 const ShapeTargetModel::ActuationRef& a,
                                                 const Eigen::VectorXd& direction,
                                                 double first_length, int max_trials,
                                                 Eigen::Matrix3Xd* x, double* energy,
                                                 Eigen::Matrix3Xd* gradient);

}  // namespace aqs

#endif  // AQS_EQUILIBRIUM_NEGATIVE_CURVATURE_H_
