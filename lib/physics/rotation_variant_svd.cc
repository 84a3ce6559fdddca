#include "physics/rotation_variant_svd.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <Eigen/LU>
#include <Eigen/SVD>

// GCC 12 reports a false -Wmaybe-uninitialized inside Eigen's 3x3 JacobiSVD.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"

namespace aqs {
namespace {

constexpr int kPairs[3][2] = {{0, 1}, {0, 2}, {1, 2}};
// Cyclic Jacobi converges quadratically: 2 to 4 sweeps in practice.
constexpr int kMaxSweeps = 12;
// A pair (p, q) of G^T G counts as decoupled when |a_pq| <= this * sqrt(a_pp a_qq).
constexpr double kJacobiTolerance = 2.2e-16;

// Cyclic Jacobi on the symmetric a: on return a is diagonal (to the tolerance) and
// a_in = v diag(a) v^T, v a product of plane rotations (det v = +1).
void SymmetricJacobi(Eigen::Matrix3d* a_in, Eigen::Matrix3d* v_out) {
  Eigen::Matrix3d& a = *a_in;
  Eigen::Matrix3d& v = *v_out;
  v.setIdentity();
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    bool rotated = false;
    for (const auto& pair : kPairs) {
      const int p = pair[0];
      const int q = pair[1];
      const double apq = a(p, q);
      if (apq * apq <= kJacobiTolerance * kJacobiTolerance * std::abs(a(p, p) * a(q, q))) continue;
      rotated = true;
      // The rotation (c, s) that zeroes a_pq; t = tan of its angle, the smaller root.
      const double theta = (a(q, q) - a(p, p)) / (2.0 * apq);
      const double t = std::abs(theta) > 1e150
                           ? 0.5 / theta
                           : std::copysign(1.0, theta) / (std::abs(theta) + std::sqrt(theta * theta + 1.0));
      const double c = 1.0 / std::sqrt(t * t + 1.0);
      const double s = t * c;
      const int r = 3 - p - q;
      a(p, p) -= t * apq;
      a(q, q) += t * apq;
      a(p, q) = a(q, p) = 0.0;
      const double arp = a(r, p);
      const double arq = a(r, q);
      a(r, p) = a(p, r) = c * arp - s * arq;
      a(r, q) = a(q, r) = s * arp + c * arq;
      for (int i = 0; i < 3; ++i) {
        const double vp = v(i, p);
        const double vq = v(i, q);
        v(i, p) = c * vp - s * vq;
        v(i, q) = s * vp + c * vq;
      }
    }
    if (!rotated) return;
  }
}

// Swaps columns i and j of u and v and negates the new column j of both: the product
// U diag(sigma) V^T and det U, det V are unchanged, sigma_i and sigma_j trade places.
void SwapPair(int i, int j, RotationVariantSvd* svd) {
  svd->u.col(i).swap(svd->u.col(j));
  svd->v.col(i).swap(svd->v.col(j));
  svd->u.col(j) *= -1.0;
  svd->v.col(j) *= -1.0;
  std::swap(svd->sigma[i], svd->sigma[j]);
}

}  // namespace

bool JacobiQrSvd(const Eigen::Matrix3d& g, RotationVariantSvd* out) {
  Eigen::Matrix3d a = g.transpose() * g;
  Eigen::Matrix3d v;
  SymmetricJacobi(&a, &v);
  // Columns of V by decreasing eigenvalue sigma_i^2, det V = +1.
  int order[3] = {0, 1, 2};
  if (a(order[0], order[0]) < a(order[1], order[1])) std::swap(order[0], order[1]);
  if (a(order[1], order[1]) < a(order[2], order[2])) std::swap(order[1], order[2]);
  if (a(order[0], order[0]) < a(order[1], order[1])) std::swap(order[0], order[1]);
  for (int i = 0; i < 3; ++i) out->v.col(i) = v.col(order[i]);
  if (out->v.determinant() < 0.0) out->v.col(2) *= -1.0;
  // B = G V = U R by Givens rotations (proper, so det U = +1); R's diagonal is sigma, with
  // R_00, R_11 >= 0 and the sign of det G left on R_22.
  Eigen::Matrix3d b = g * out->v;
  Eigen::Matrix3d& u = out->u;
  u.setIdentity();
  auto givens = [&b, &u](int i, int j, int column) {
    const double x = b(i, column);
    const double y = b(j, column);
    const double h = std::sqrt(x * x + y * y);
    if (h == 0.0) return;
    const double c = x / h;
    const double s = y / h;
    for (int k = 0; k < 3; ++k) {
      const double bi = b(i, k);
      const double bj = b(j, k);
      b(i, k) = c * bi + s * bj;
      b(j, k) = c * bj - s * bi;
      const double ui = u(k, i);
      const double uj = u(k, j);
      u(k, i) = c * ui + s * uj;
      u(k, j) = c * uj - s * ui;
    }
  };
  givens(0, 1, 0);
  givens(0, 2, 0);
  givens(1, 2, 1);
  out->sigma = b.diagonal();
  // A zero first column (G = 0 or rank deficient in the first direction) leaves R_00 = 0
  // with no rotation: still a valid, non-negative value.
  const double residual = std::max({std::abs(b(0, 1)), std::abs(b(0, 2)), std::abs(b(1, 2))});
  if (!(residual <= kSvdResidualRatio * out->sigma[0]) && !(out->sigma[0] == 0.0 && residual == 0.0)) {
    return false;
  }
  if (out->sigma[0] < 0.0 || out->sigma[1] < 0.0) return false;
  // Rounding can leave near-equal values out of order: restore sigma_0 >= sigma_1 >= |sigma_2|.
  if (out->sigma[0] < out->sigma[1]) SwapPair(0, 1, out);
  if (out->sigma[1] < std::abs(out->sigma[2])) {
    SwapPair(1, 2, out);
    if (out->sigma[1] < 0.0) {  // keep the sign on sigma_2: negate both columns of U
      out->u.col(1) *= -1.0;
      out->u.col(2) *= -1.0;
      out->sigma[1] = -out->sigma[1];
      out->sigma[2] = -out->sigma[2];
    }
    if (out->sigma[0] < out->sigma[1]) SwapPair(0, 1, out);
  }
  return true;
}

RotationVariantSvd RotationVariantSvdReference(const Eigen::Matrix3d& g) {
  Eigen::JacobiSVD<Eigen::Matrix3d, Eigen::NoQRPreconditioner> svd(
      g, Eigen::ComputeFullU | Eigen::ComputeFullV);
  RotationVariantSvd out;
  out.u = svd.matrixU();
  out.v = svd.matrixV();
  out.sigma = svd.singularValues();
  // Move reflections into the smallest singular value so both factors are rotations.
  if (out.u.determinant() < 0) {
    out.u.col(2) *= -1.0;
    out.sigma[2] *= -1.0;
  }
  if (out.v.determinant() < 0) {
    out.v.col(2) *= -1.0;
    out.sigma[2] *= -1.0;
  }
  return out;
}

RotationVariantSvd ComputeRotationVariantSvd(const Eigen::Matrix3d& g) {
  RotationVariantSvd out;
  if (!g.allFinite()) {  // NaN throughout, so that energies and forces report it
    const double nan = std::numeric_limits<double>::quiet_NaN();
    out.u.setConstant(nan);
    out.v.setConstant(nan);
    out.sigma.setConstant(nan);
    return out;
  }
  if (JacobiQrSvd(g, &out)) return out;
  return RotationVariantSvdReference(g);
}

}  // namespace aqs
