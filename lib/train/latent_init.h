#ifndef AQS_TRAIN_LATENT_INIT_H_
#define AQS_TRAIN_LATENT_INIT_H_

#include <vector>

#include <Eigen/Core>

namespace aqs {

// Principal-component scores of P samples (columns of `samples`, D x P, weighted per
// row by `row_weights` (D, >= 0)) about a centre, whitened: a latent_dim x P matrix
// whose row k is the k-th component's scores scaled so that their squares sum to
// P - 1 over the samples (unit variance when the centre is the mean). The centre is
// the samples' mean, or `*center` (D) if given: then the components are those of the
// uncentered displacements from it, and a sample equal to the centre scores zero.
// Rows beyond the number of non-trivial components (at most P - 1 about the mean, P
// about another centre) are zero. Computed through the P x P Gram matrix, so D may be
// millions. Used to start latents.
Eigen::MatrixXd WhitenedPcaScores(const Eigen::MatrixXd& samples, const Eigen::VectorXd& row_weights,
                                  int latent_dim, const Eigen::VectorXd* center = nullptr);

}  // namespace aqs

#endif  // AQS_TRAIN_LATENT_INIT_H_
