#include "train/latent_init.h"

#include <cmath>

#include <Eigen/Eigenvalues>
#include <glog/logging.h>

namespace aqs {

Eigen::MatrixXd WhitenedPcaScores(const Eigen::MatrixXd& samples, const Eigen::VectorXd& row_weights,
                                  int latent_dim, const Eigen::VectorXd* center) {
  CHECK_EQ(samples.rows(), row_weights.size());
  if (center != nullptr) CHECK_EQ(center->size(), samples.rows());
  const Eigen::Index p = samples.cols();
  Eigen::MatrixXd centered =
      samples.colwise() - (center != nullptr ? *center : Eigen::VectorXd(samples.rowwise().mean()));
  centered = row_weights.cwiseSqrt().asDiagonal() * centered;
  const Eigen::MatrixXd gram = centered.transpose() * centered;  // P x P
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(gram);
  Eigen::MatrixXd scores = Eigen::MatrixXd::Zero(latent_dim, p);
  const double largest = eig.eigenvalues().maxCoeff();
  for (int k = 0; k < latent_dim && k < p; ++k) {
    const Eigen::Index j = p - 1 - k;  // eigenvalues ascend
    const double lambda = eig.eigenvalues()[j];
    if (!(lambda > 1e-12 * largest) || lambda <= 0) break;
    // Scores of component k are sqrt(lambda) u (|u| = 1); whitened: u sqrt(P - 1).
    scores.row(k) = eig.eigenvectors().col(j).transpose() * std::sqrt(std::max<double>(1, p - 1));
  }
  return scores;
}

}  // namespace aqs
