#include "train/pretrain_objective.h"

#include <cmath>

namespace aqs {

PretrainObjective::PretrainObjective(const ActuationDecoder& decoder,
                                     const std::vector<ActuationMatrix>& targets,
                                     const Eigen::VectorXd& element_weights,
                                     double latent_regularization,
                                     double decoder_regularization)
    : decoder_(decoder),
      targets_(targets),
      weights_(element_weights),
      regularization_(latent_regularization),
      decoder_regularization_(decoder_regularization) {}

int PretrainObjective::NumParameters() const {
  return decoder_.num_parameters() + decoder_.latent_dim() * static_cast<int>(targets_.size());
}

double PretrainObjective::Loss(const double* parameters, double* gradient, double* mse) const {
  const int np = decoder_.num_parameters();
  const int d = decoder_.latent_dim();
  const int p = static_cast<int>(targets_.size());
  const Eigen::Map<const Eigen::MatrixXd> latents(parameters + np, d, p);
  std::vector<ActuationMatrix> a;
  DecoderWorkspace workspace;
  decoder_.DecodeBatch(parameters, latents, &a, &workspace);
  double data = 0.0;
  std::vector<ActuationMatrix> dl_da(p);
  for (int i = 0; i < p; ++i) {
    const ActuationMatrix diff = a[i] - targets_[i];
    const ActuationMatrix weighted =
        ActuationEntryWeights().asDiagonal() * diff * weights_.asDiagonal();  // 6 x m
    data += (weighted.array() * diff.array()).sum() / p;
    if (gradient != nullptr) dl_da[i] = (2.0 / p) * weighted;
  }
  const Eigen::Map<const Eigen::VectorXd> params(parameters, np);
  const double reg = regularization_ * latents.squaredNorm() / p +
                     decoder_regularization_ * params.squaredNorm();
  if (mse != nullptr) *mse = data;
  if (gradient != nullptr) {
    Eigen::Map<Eigen::VectorXd> g(gradient, NumParameters());
    g.setZero();
    // Held latents: no back-propagation to them (their entries stay zero).
    Eigen::MatrixXd latent_gradient;
    decoder_.Backward(parameters, workspace, dl_da, gradient,
                      hold_latents_ ? nullptr : &latent_gradient);
    g.head(np) += (2.0 * decoder_regularization_) * params;
    if (!hold_latents_) {
      Eigen::Map<Eigen::MatrixXd>(gradient + np, d, p) =
          latent_gradient + (2.0 * regularization_ / p) * latents;
    }
  }
  return data + reg;
}

bool PretrainObjective::Evaluate(const double* parameters, double* cost,
                                 double* gradient) const {
  *cost = Loss(parameters, gradient, nullptr);
  return std::isfinite(*cost);
}

}  // namespace aqs
