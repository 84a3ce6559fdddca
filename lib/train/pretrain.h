#ifndef AQS_TRAIN_PRETRAIN_H_
#define AQS_TRAIN_PRETRAIN_H_

#include <ostream>
#include <string>

#include "learn/decoder.h"
#include "learn/grid_actuation_field.h"
#include "model/active_model.h"

namespace aqs {

struct PretrainOptions {
  DecoderSpec spec;                 // latent dimension, layers, activation, output scale
  GridActuationFieldOptions field;  // the decoder's output grid
  // Weight of the latent regularizer (1/P) sum_p |z_p|^2.
  double latent_regularization = 1e-3;
  int max_iterations = 500;
  unsigned seed = 1;
  int num_threads = 2;
  // Progress line every this many iterations (0: none).
  int log_every = 25;
};

struct PretrainReport {
  int iterations = 0;
  double initial_loss = 0.0;
  double final_loss = 0.0;
  // sqrt of the volume-weighted mean squared actuation error |a - S|_F^2 over poses
  // and elements, at the end (in strain units: 0.01 = 1%).
  double rms_actuation_error = 0.0;
  double seconds = 0.0;
  std::string termination;
};

// Pre-training: a supervised fit of a new decoder and one latent per pose to the
// model's volumetric targets (an auto-decoder; equivalent to training an auto-encoder
// and keeping its decoder and codes):
//
//   min over params, z_1..z_P of  (1/P) sum_p sum_e w_e |a_e(z_p) - S_pe|_F^2
//                                 + latent_regularization (1/P) sum_p |z_p|^2,
//
// with w_e = V_e / sum V (|.|_F the Frobenius norm of the 3x3 matrices), by Ceres'
// L-BFGS (GradientProblemSolver). Latents start at the whitened principal components
// of the targets, parameters at random (small outputs). Every pose needs a target.
// Sets model->decoder, decoder_params and latents, and clears the states and the
// training checkpoint (they belonged to the old decoder). Progress lines go to `log`.
bool Pretrain(const PretrainOptions& options, ActiveModel* model, PretrainReport* report,
              std::ostream& log, std::string* error);

}  // namespace aqs

#endif  // AQS_TRAIN_PRETRAIN_H_
