#ifndef AQS_MODEL_FIT_PRIOR_H_
#define AQS_MODEL_FIT_PRIOR_H_

#include <string>
#include <vector>

#include <Eigen/Core>

namespace aqs {

struct ActiveModel;

// A Gaussian N(mean, covariance) over n numbers, with the whitening W = L^-1 of the
// Cholesky factor covariance = L L^T, so that |W (x - mean)|^2 is the squared
// Mahalanobis distance. mean: n; covariance, whitening: n x n.
struct GaussianPrior {
  Eigen::VectorXd mean;
  Eigen::MatrixXd covariance;
  Eigen::MatrixXd whitening;

  int size() const { return static_cast<int>(mean.size()); }
  // Sets covariance and whitening; false if the covariance is not symmetric positive
  // definite (then nothing changes).
  bool SetCovariance(const Eigen::MatrixXd& covariance);
  double SquaredMahalanobis(const Eigen::VectorXd& x) const;
};

// The priors of fits (lib/fit): where a model's latent and each bone's rigid motion
// are likely to be, learned from the training poses. Bone motions are the 6 fit
// parameters: rotation vector (radians) and translation of x -> R x + t.
struct FitPrior {
  std::string center;  // the training pose the priors are centred on; "" : the mean
  GaussianPrior latent;               // latent_dim numbers
  std::vector<GaussianPrior> bones;   // 6 numbers per bone, in the model's bone order

  bool empty() const { return latent.size() == 0; }
};

struct FitPriorOptions {
  // Added to the latent covariance's diagonal: this fraction of its mean variance (keeps
  // it definite when directions have no spread in the training latents).
  double latent_floor = 0.01;
  // Lower bounds on each bone parameter's standard deviation: rotation (radians) the
  // larger of rotation_floor and rotation_floor_fraction x the largest rotation
  // standard deviation; translation the larger of translation_floor_fraction x the
  // largest translation standard deviation and 1e-3 x the rest mesh's bounding-box
  // diagonal. Directions the training poses never moved the bone in get these.
  double rotation_floor = 0.01;
  double rotation_floor_fraction = 0.1;
  double translation_floor_fraction = 0.1;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// Whether `surface` is the neutral (both 3 x N): its largest vertex distance from it is
// at most 1e-6 x the neutral's bounding-box diagonal. The first training pose that is
// the neutral centres a fit prior (LearnFitPrior).
bool IsNeutralSurface(const Eigen::Matrix3Xd& surface, const Eigen::Matrix3Xd& neutral);

// Training latents whose mean variance is at most this have no spread to learn from.
inline constexpr double kNoLatentSpread = 1e-12;

// The latent prior of a fit (FitPrior::latent) learned from training latents (d x P,
// P >= 1): centred on latents.col(center) for center >= 0 (the neutral's training pose),
// else on their mean; its covariance is the second moment of the latents about that
// centre, plus options.latent_floor x its mean variance on the diagonal. Latents without
// spread (one pose, or all alike: kNoLatentSpread) give (1 + latent_floor) I instead,
// unit variance being the scale of the whitened latents training starts from.
// LearnFitPrior's latent part, and the evaluation's auto-encoder's
// (eval/surface_autoencoder.h). False, with *error saying why, where that covariance is
// not finite and positive definite.
bool LearnLatentPrior(const Eigen::MatrixXd& latents, int center, const FitPriorOptions& options,
                      GaussianPrior* prior, std::string* error);

// Learns the priors of a trained model (CHECK: a decoder) from its training latents
// and bone transforms. Both are centred on the training pose whose surface is the
// neutral (IsNeutralSurface), so that where data says nothing fits fall back to the
// neutral face; without such a pose, on the mean training latent and bones at rest.
// The covariances are the second moments of the training latents / bone parameters
// about that centre, with the floors of `options` (the latent part: LearnLatentPrior).
// False, with *error saying why, where no prior can be learned: no training poses, or
// training latents or bone motions so far apart (a damaged model) that their
// covariance is not finite and positive definite.
bool LearnFitPrior(const ActiveModel& model, const FitPriorOptions& options, FitPrior* prior,
                   std::string* error);
// The same for a model known to give one (CHECK: it does), e.g. one just trained.
FitPrior LearnFitPrior(const ActiveModel& model, const FitPriorOptions& options = {});

// The prior file (docs/model_format.md, "prior.txt"): text, '#' comments;
//   center <pose name or ->
//   latent_mean m_1 ... m_d
//   latent_covariance <i> c_i1 ... c_id        (d lines, i = 0 .. d-1)
//   bone <name> mean p_1 ... p_6
//   bone <name> covariance <i> c_i1 ... c_i6   (6 lines per bone)
// Written atomically; numbers read back bit for bit (util/number_format.h).
bool WriteFitPrior(const std::string& path, const FitPrior& prior,
                   const std::vector<std::string>& bone_names, std::string* error);
// Reads a prior for a model with this latent size and these bones (every bone needs
// its lines). Errors name path:line: wrong counts, unknown bones, missing rows, a
// covariance that is not symmetric positive definite.
bool ReadFitPrior(const std::string& path, int latent_dim,
                  const std::vector<std::string>& bone_names, FitPrior* prior,
                  std::string* error);

}  // namespace aqs

#endif  // AQS_MODEL_FIT_PRIOR_H_
