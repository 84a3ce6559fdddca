#ifndef AQS_TRAIN_LATENT_INIT_H_
#define AQS_TRAIN_LATENT_INIT_H_

#include <vector>

#include <Eigen/Core>

namespace aqs {

// Principal-component scores of P samples (columns of `samples`, D x P, weighted per
// row by `row_weights` (D, >= 0)) around their mean, whitened: a latent_dim x P matrix
// whose row k is the k-th component's scores divided by their standard deviation.
// Rows beyond the number of non-trivial components (at most P - 1) are zero. Computed
// through the P x P Gram matrix, so D may be millions. Used to start latents.
Eigen::MatrixXd WhitenedPcaScores(const Eigen::MatrixXd& samples, const Eigen::VectorXd& row_weights,
                                  int latent_dim);

}  // namespace aqs

#endif  // AQS_TRAIN_LATENT_INIT_H_
