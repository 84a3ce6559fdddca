#include "eval/surface_pca.h"

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
  for (Eigen::Index j = p - 1; j >= 0 && static_cast<int>(columns.size()) < k; --j) {
    const double lambda = eig.eigenvalues()[j];
    if (!(lambda > 1e-12 * largest) || lambda <= 0) break;
    columns.push_back(x * eig.eigenvectors().col(j) / std::sqrt(lambda));
  }
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
  const Eigen::Index k = num_components();
  Eigen::MatrixXd a(3 * vertices.size(), k);
  Eigen::VectorXd b(3 * vertices.size());
  for (size_t i = 0; i < vertices.size(); ++i) {
    a.middleRows(3 * i, 3) = basis_.middleRows(3 * vertices[i], 3);
    b.segment<3>(3 * i) = positions.col(i) - mean_.segment<3>(3 * vertices[i]);
  }
  const Eigen::VectorXd c = k > 0 ? Eigen::VectorXd(a.colPivHouseholderQr().solve(b))
                                  : Eigen::VectorXd();
  return Decode(c);
}

}  // namespace aqs
