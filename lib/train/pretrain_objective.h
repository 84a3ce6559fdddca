#ifndef AQS_TRAIN_PRETRAIN_OBJECTIVE_H_
#define AQS_TRAIN_PRETRAIN_OBJECTIVE_H_

#include <vector>

#include <Eigen/Core>
#include <ceres/first_order_function.h>

#include "learn/decoder.h"
#include "physics/actuation.h"

namespace aqs {

// Frobenius weights of an actuation's six numbers (xx yy zz xy xz yz; off-diagonals
// appear twice in the symmetric matrix).
inline const Vector6d& ActuationEntryWeights() {
  static const Vector6d weights = (Vector6d() << 1, 1, 1, 2, 2, 2).finished();
  return weights;
}

// Pre-training's objective (internal to train/pretrain.cc; a header of its own so that
// its gradient has a finite-difference test). Over x = [params; z_1; ...; z_P] (decoder
// parameters, then the P latents of latent_dim each, pose-major):
//   L(x) = (1/P) sum_p sum_e w_e |a_p,e - S_p,e|_F^2
//        + lambda_z (1/P) sum_p |z_p|^2 + lambda_w |params|^2,
// a_p = decoder(params, z_p) (6 x m, the element actuations), S_p = targets[p] (6 x m),
// w = element_weights (m). The decoder and the targets are held by reference and must
// outlive the objective.
class PretrainObjective final : public ceres::FirstOrderFunction {
 public:
  PretrainObjective(const ActuationDecoder& decoder, const std::vector<ActuationMatrix>& targets,
                    const Eigen::VectorXd& element_weights, double latent_regularization,
                    double decoder_regularization);

  // num_parameters + latent_dim * P.
  int NumParameters() const override;

  // L(x); its gradient dL/dx (NumParameters()) into `gradient` unless null; the data term
  // alone (the weighted mean actuation error) into *mse unless null.
  double Loss(const double* parameters, double* gradient, double* mse) const;

  // With hold = true the latents' gradient entries are zero (the loss is unchanged):
  // a gradient method then moves the decoder parameters alone. Default false.
  void HoldLatents(bool hold) { hold_latents_ = hold; }

  // Loss, for Ceres; false where it is not finite.
  bool Evaluate(const double* parameters, double* cost, double* gradient) const override;

 private:
  const ActuationDecoder& decoder_;
  const std::vector<ActuationMatrix>& targets_;
  Eigen::VectorXd weights_;
  double regularization_;
  double decoder_regularization_;
  bool hold_latents_ = false;
};

}  // namespace aqs

#endif  // AQS_TRAIN_PRETRAIN_OBJECTIVE_H_
