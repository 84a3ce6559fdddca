#include "eval/surface_pca.h"

#include <algorithm>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <glog/logging.h>

namespace aqs {

SurfacePca::SurfacePca(const std::vector<Eigen::Matrix3Xd>& surfaces, int k,
                       const Eigen::Matrix3Xd* center) {
  CHECK(!surfaces.empty());
  const Eigen::Index n = surfaces[0].size();
  const Eigen::Index p = static_cast<Eigen::Index>(surfaces.size());
  Eigen::MatrixXd x(n, p);
  for (Eigen::Index i = 0; i < p; ++i) {
    CHECK_EQ(surfaces[i].size(), n);
    x.col(i) = Eigen::Map<const Eigen::VectorXd>(surfaces[i].data(), n);
  }
  if (center != nullptr) {
    CHECK_EQ(center->size(), n);
    mean_ = Eigen::Map<const Eigen::VectorXd>(center->data(), n);
  } else {
    mean_ = x.rowwise().mean();
  }
  x.colwise() -= mean_;
  // Through the P x P Gram matrix: X = U S V^T, U = X V S^-1.
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(x.transpose() * x);
  const double largest = std::max(eig.eigenvalues().maxCoeff(), 0.0);
  std::vector<Eigen::VectorXd> columns;
  std::vector<double> variances;
  for (Eigen::Index j = p - 1; j >= 0 && static_cast<int>(columns.size()) < k; --j) {
    const double lambda = eig.eigenvalues()[j];
    if (!(lambda > 1e-12 * largest) || lambda <= 0) break;
    columns.push_back(x * eig.eigenvectors().col(j) / std::sqrt(lambda));
    variances.push_back(lambda / static_cast<double>(p));
  }
  variances_ = Eigen::Map<const Eigen::VectorXd>(variances.data(), variances.size());
  basis_.resize(n, columns.size());
  for (size_t c = 0; c < columns.size(); ++c) basis_.col(c) = columns[c];
}

Eigen::VectorXd SurfacePca::Encode(const Eigen::Matrix3Xd& surface) const {
  return basis_.transpose() * (Eigen::Map<const Eigen::VectorXd>(surface.data(), surface.size()) - mean_);
}

Eigen::Matrix3Xd SurfacePca::Decode(const Eigen::VectorXd& coefficients) const {
  const Eigen::VectorXd flat = mean_ + basis_ * coefficients;
  return Eigen::Map<const Eigen::Matrix3Xd>(flat.data(), 3, flat.size() / 3);
}

Eigen::Matrix3Xd SurfacePca::FitToVertices(const std::vector<int>& vertices,
                                           const Eigen::Matrix3Xd& positions) const {
  return FitToVerticesRidge(vertices, positions, 0.0);
}

Eigen::Matrix3Xd SurfacePca::FitToVerticesRidge(const std::vector<int>& vertices,
                                                const Eigen::Matrix3Xd& positions,
                                                double ridge) const {
  const Eigen::Index k = num_components();
  Eigen::MatrixXd a(3 * vertices.size(), k);
  Eigen::VectorXd b(3 * vertices.size());
  for (size_t i = 0; i < vertices.size(); ++i) {
    a.middleRows(3 * i, 3) = basis_.middleRows(3 * vertices[i], 3);
    b.segment<3>(3 * i) = positions.col(i) - mean_.segment<3>(3 * vertices[i]);
  }
  if (k == 0) return Decode(Eigen::VectorXd());
  if (ridge <= 0) {
    // Least squares; where the markers leave coefficients free, the solution of least
    // sum_j c_j^2 / variances_j (the limit of small ridges): c = W^1/2 u, u the
    // minimum-norm solution of A W^1/2 u = b, W = diag(variances).
    const Eigen::VectorXd scale = variances_.cwiseSqrt();
    const Eigen::MatrixXd scaled = a * scale.asDiagonal();
    return Decode(scale.cwiseProduct(scaled.completeOrthogonalDecomposition().solve(b)));
  }
  Eigen::MatrixXd normal = a.transpose() * a;
  for (Eigen::Index j = 0; j < k; ++j) normal(j, j) += ridge / variances_[j];
  return Decode(normal.ldlt().solve(a.transpose() * b));
}

RidgeChoice ChooseRidgeLeaveOneOut(const std::vector<Eigen::Matrix3Xd>& surfaces, int k,
                                   const std::vector<int>& marker_vertices,
                                   const std::vector<int>& error_vertices,
                                   const std::vector<double>& candidates) {
  CHECK_GE(surfaces.size(), 3u);
  CHECK(!candidates.empty());
  const int p = static_cast<int>(surfaces.size());
  const int components = std::min(k, p - 2);
  std::vector<int> measured = error_vertices;
  if (measured.empty()) {
    for (Eigen::Index v = 0; v < surfaces[0].cols(); ++v) measured.push_back(static_cast<int>(v));
  }
  RidgeChoice choice;
  choice.candidates = candidates;
  choice.errors.assign(candidates.size(), 0.0);
  for (int left = 0; left < p; ++left) {
    std::vector<Eigen::Matrix3Xd> others;
    for (int q = 0; q < p; ++q) {
      if (q != left) others.push_back(surfaces[q]);
    }
    const SurfacePca pca(others, components);
    const Eigen::Matrix3Xd markers = surfaces[left](Eigen::all, marker_vertices);
    for (size_t c = 0; c < candidates.size(); ++c) {
      const Eigen::Matrix3Xd fit = pca.FitToVerticesRidge(marker_vertices, markers, candidates[c]);
      double sum = 0.0;
      for (int v : measured) sum += (fit.col(v) - surfaces[left].col(v)).norm();
      choice.errors[c] += sum / measured.size() / p;
    }
  }
  size_t best = 0;
  for (size_t c = 1; c < candidates.size(); ++c) {
    if (choice.errors[c] < choice.errors[best]) best = c;
  }
  choice.ridge = candidates[best];
  choice.loo_error = choice.errors[best];
  return choice;
}

}  // namespace aqs
