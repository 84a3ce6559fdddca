#ifndef AQS_EVAL_SURFACE_AUTOENCODER_H_
#define AQS_EVAL_SURFACE_AUTOENCODER_H_

#include <memory>
#include <ostream>
#include <string>
#include <vector>

#include <ceres/cost_function.h>
#include <ceres/first_order_function.h>
#include <Eigen/Core>

#include "learn/mlp.h"
#include "model/fit_prior.h"
#include "train/solver_checkpoint.h"

namespace aqs {

struct LatentFitOptions;

// The surface-only baseline of the evaluation: a decoder from a latent z straight to
// the surface, trained on the same poses with the same network machinery (Mlp,
// auto-decoder, whitened-PCA latent start, Ceres L-BFGS) but without the simulator.
struct SurfaceAutoencoderOptions {
  // Dimension d of the latent vector z.
  int latent_dim = 16;
  std::vector<int> hidden_dims = {128, 128};
  Activation activation = Activation::kElu;
  // The MLP's outputs are multiplied by output_scale to give displacements in model
  // units: surface(z) = neutral + output_scale * mlp(z).
  double output_scale = 1.0;
  // Anchored at the origin: surface(z) = neutral + output_scale (mlp(z) - mlp(0)), so that
  // z = 0 decodes to the neutral exactly (as the physics decoder's anchored option).
  bool anchored = false;
  // A linear part beside the network: surface(z) = neutral + output_scale (mlp(z) + W z)
  // (as the physics decoder's linear_skip option).
  bool linear_skip = false;
  // Weight lambda of the latent regularizer lambda (1/P) sum_p |z_p|^2 in training (the
  // training regularizer of the physics model, TrainOptions::latent_regularization).
  // FitLatent's prior is not this one but the physics fits' (LatentFitOptions).
  double latent_regularization = 1e-3;
  // L-BFGS iterations in all (counting those of a resumed checkpoint's run).
  int max_iterations = 500;
  // L-BFGS restarts from the accepted point, with an empty memory, allowed where a
  // solve stalls before max_iterations (Ceres' CONVERGENCE or FAILURE: a line search
  // that finds no step): the rule and default of end-to-end training
  // (TrainOptions::max_restarts, train/lbfgs_restarts.h).
  int max_restarts = 50;
  // Ceres' function_tolerance of each L-BFGS solve, in [0, 1): a solve ends when an
  // iteration lowers the loss by less than this fraction of it (then L-BFGS restarts,
  // max_restarts).
  double function_tolerance = 1e-12;
  // L-BFGS' initial inverse Hessian scaled by s^T y / y^T y of the last step (Ceres'
  // use_approximate_eigenvalue_bfgs_scaling), as end-to-end training does
  // (TrainOptions::lbfgs_scaling).
  bool lbfgs_scaling = true;
  // Seed of the MLP's random initial weights.
  unsigned seed = 1;
  // Progress line every this many L-BFGS iterations (0: none).
  int log_every = 0;
  // Checkpoints of training (train/solver_checkpoint.h) go into this folder (empty:
  // none), at most every checkpoint_seconds of iterations (0: every iteration) and at the
  // end; a checkpoint there of the same surfaces and options (all but max_iterations,
  // max_restarts, function_tolerance, log_every and the checkpoint fields) is resumed,
  // its iterations counting towards max_iterations (L-BFGS' memory starts anew there).
  std::string checkpoint_directory;
  double checkpoint_seconds = 60.0;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// What a checkpoint of SurfaceAutoencoder::Train belongs to (train/solver_checkpoint.h):
// "surfaces", a hash of the neutral and the training surfaces, and "options", every
// option that shapes the result (not the budget and stopping rules max_iterations,
// max_restarts and function_tolerance, nor log_every or the checkpoints').
CheckpointKey AutoencoderCheckpointKey(const SurfaceAutoencoderOptions& options,
                                       const Eigen::Matrix3Xd& neutral,
                                       const std::vector<Eigen::Matrix3Xd>& surfaces);

struct SurfaceAutoencoderReport {
  int iterations = 0;         // in all runs (iterations_before included)
  int iterations_before = 0;  // done by an earlier run (from its checkpoint)
  int restarts = 0;           // L-BFGS restarts after a stall, in this run
  // The loss at the training's start (its first run's start, also when this run
  // resumed a checkpoint), and at the checkpoint this run resumed (0: none).
  double initial_loss = 0.0;
  double resumed_loss = 0.0;
  double final_loss = 0.0;
  // sqrt of the data term at the end: the RMS distance between the decoded and the
  // training surfaces over all surfaces and vertices (model units).
  double rms_error = 0.0;
  // The largest such distance of any vertex of any training surface.
  double max_error = 0.0;
  double seconds = 0.0;
  std::string termination;
};

// The training objective of SurfaceAutoencoder::Train as a Ceres FirstOrderFunction over
// the flat vector x = [mlp parameters (mlp.num_parameters(), Mlp layout); z_1; ...; z_P
// (latent_dim each, i.e. a d x P column-major block)]:
//
//   L(x) = (1/(P N)) sum_p sum_i |s m_i(z_p) - D_pi|^2 + lambda (1/P) sum_p |z_p|^2,
//
// with m_i(z) the 3 outputs of vertex i (rows 3i .. 3i+2 of mlp(z)), s = output_scale
// and D_pi = y_pi - neutral_i the training displacements, so that s m_i(z_p) - D_pi =
// surface_i(z_p) - y_pi. `displacements` is 3N x P (column p: pose p's displacements,
// flattened x0 y0 z0 x1 ...); the mlp must map latent_dim -> 3N. Both are kept by
// reference and must outlive the objective. The gradient (same layout as x) comes from
// one batched forward and backward pass (Mlp::Backward). Public for tests; not
// thread-safe (it keeps its batch workspace between calls).
class SurfaceAutoencoderObjective final : public ceres::FirstOrderFunction {
 public:
  SurfaceAutoencoderObjective(const Mlp& mlp, const Eigen::MatrixXd& displacements,
                              double output_scale, double latent_regularization);

  int NumParameters() const override;
  int num_surfaces() const { return static_cast<int>(displacements_.cols()); }

  // L(x) and, if gradient is not null, dL/dx (NumParameters()). If mean_squared_distance
  // is not null it receives the data term alone, and if max_distance is not null the
  // largest vertex distance |surface_i(z_p) - y_pi|.
  double Loss(const double* parameters, double* gradient, double* mean_squared_distance = nullptr,
              double* max_distance = nullptr) const;

  // Loss() for Ceres; false (a failed step) if the cost is not finite, or where a test's
  // failure hook says so at "autoencoder:evaluate" (util/fault_injection.h).
  bool Evaluate(const double* parameters, double* cost, double* gradient) const override;

 private:
  const Mlp& mlp_;
  const Eigen::MatrixXd& displacements_;
  const double output_scale_;
  const double latent_regularization_;
  mutable MlpWorkspace workspace_;
  mutable Eigen::MatrixXd outputs_;  // 3N x P; reused as dL/doutputs
};

// A surface-only auto-encoder (trained as an auto-decoder):
//
//   surface(z) = neutral + output_scale * reshape(mlp(z)),   z in R^d,
//
// where mlp: R^d -> R^(3N) gives the per-vertex displacements, flattened column-major
// (x0 y0 z0 x1 ...), reshaped to 3 x N. Train() fits the network weights and one latent
// per training surface; FitLatent() finds the latent whose surface best matches given
// points with the decoder fixed (the baseline's counterpart of LatentFitter).
//
// Cost for N vertices and last hidden width h: the parameters are about 3N (h + 1)
// doubles (21 MB for N = 13,294 and h = 64, 41 MB for h = 128). Training holds about 40
// arrays of that size (the iterate, its gradient, Ceres' line-search samples and the
// L-BFGS history of rank 10: 2 x 10 arrays; measured peak 0.8 GB for N = 13,294, h = 64,
// P = 12), plus 3N x P doubles for the training displacements and outputs. There, one
// objective evaluation (three products with the output layer) takes about 20 ms, and
// Ceres' L-BFGS bookkeeping on the long vector (the two-loop recursion: 40 passes;
// line-search copies) several times that: it dominates the time per iteration.
// The memory (bytes) training an auto-encoder with `options` on num_surfaces surfaces of
// num_vertices vertices takes, by the count above (about 40 arrays of its parameters,
// counted in 64 bits, and the 3N x P matrices): to refuse, before any work, a network
// that would exhaust memory (or overflow an int's parameter count, which Mlp CHECKs).
double SurfaceAutoencoderMemoryBytes(const SurfaceAutoencoderOptions& options,
                                     int num_vertices, int num_surfaces);

class SurfaceAutoencoder {
 public:
  SurfaceAutoencoder();
  ~SurfaceAutoencoder();
  SurfaceAutoencoder(SurfaceAutoencoder&&) noexcept;
  SurfaceAutoencoder& operator=(SurfaceAutoencoder&&) noexcept;

  // Trains a new decoder (replacing any previous one) on `surfaces` (P of them, each
  // 3 x N, the same vertex order as `neutral`, 3 x N):
  //
  //   min over mlp params, z_1..z_P of
  //     (1/(P N)) sum_p sum_i |surface_i(z_p) - y_pi|^2 + latent_regularization (1/P) sum_p |z_p|^2
  //
  // (the normalization of the physics model's end-to-end loss, so that the numbers
  // compare) by Ceres' L-BFGS (GradientProblemSolver, rank 10), restarted where it stalls
  // before max_iterations as end-to-end training's is (RunLbfgsWithRestarts, up to
  // max_restarts times; the report and the log count the restarts). Latents start at the
  // whitened principal-component scores of the training displacements
  // (WhitenedPcaScores: about their mean, where the physics model's, with
  // --pretrain_latents=surfaces, are about the neutral), the weights at random
  // (Mlp::InitializeParameters with output gain 0.1) and the output bias at the mean
  // displacement / output_scale (with `anchored` the bias cancels: the start is near the
  // neutral). The result
  // is the last point L-BFGS accepted, with or without checkpoints. Then learns the
  // latent prior of fits from the trained latents as the physics model's is learned
  // (latent_prior()). Progress lines go to `log`. Returns false with *error (and leaves
  // the object unchanged) for no surfaces, a vertex-count mismatch, non-finite
  // coordinates, invalid options, or trained latents that give no prior.
  bool Train(const Eigen::Matrix3Xd& neutral, const std::vector<Eigen::Matrix3Xd>& surfaces,
             const SurfaceAutoencoderOptions& options, std::ostream& log, std::string* error);

  bool trained() const { return mlp_ != nullptr; }
  int latent_dim() const { return options_.latent_dim; }
  int num_vertices() const { return static_cast<int>(neutral_.cols()); }
  const SurfaceAutoencoderOptions& options() const { return options_; }
  const SurfaceAutoencoderReport& report() const { return report_; }
  const Mlp& mlp() const { return *mlp_; }
  // The flat MLP parameters (mlp().num_parameters(), Mlp layout).
  const Eigen::VectorXd& parameters() const { return parameters_; }
  // The trained latents, d x P (column p: training surface p).
  const Eigen::MatrixXd& training_latents() const { return latents_; }
  // The mean of the training latents (d): a neutral starting point for FitLatent.
  Eigen::VectorXd MeanLatent() const { return latents_.rowwise().mean(); }
  // The prior of FitLatent's latent, learned from the training latents by the physics
  // model's rule (LearnLatentPrior with the default FitPriorOptions, as LearnFitPrior):
  // centred on the latent of the first training surface that is the neutral
  // (IsNeutralSurface), else on the mean latent; covariance their second moment about
  // that centre with the latent floor.
  const GaussianPrior& latent_prior() const { return latent_prior_; }

  // surface(z) (3 x N) for z (latent_dim). CHECKs that the model is trained.
  Eigen::Matrix3Xd Decode(const Eigen::VectorXd& z) const;

  // Fits the latent to K points with the decoder fixed, starting from `initial` (d),
  // with the priors of the physics model's fits (LatentFitter) weighed by the same
  // options `fit` (its latent_prior, prior_points_cap and legacy latent_regularization;
  // the rest of `fit` concerns the physics fit only):
  //
  //   min_z  (1/K) sum_k |surface_{v_k}(z) - y_k|^2 + FitPriorTerm(z, K, fit),
  //
  // with v_k = vertices[k] and y_k = positions.col(k) (positions: 3 x K), as a Ceres
  // least-squares problem (Levenberg-Marquardt, DENSE_QR, at most 100 iterations) with
  // residuals sqrt(1/K) (surface_{v_k}(z) - y_k) (3K), the prior's
  // sqrt(fit.latent_prior / min(K, fit.prior_points_cap)) L^-1 (z - mean) (d;
  // GaussianPriorCost of latent_prior(), where fit.latent_prior > 0) and
  // sqrt(fit.latent_regularization) z (d, where > 0), and analytic Jacobians
  // (Mlp::InputJacobian of an MLP restricted to the 3K outputs of the listed vertices,
  // so one evaluation costs about d forward passes of a 3K-output network). Sets *z (d)
  // and *rms = sqrt((1/K) sum_k |surface_{v_k}(z) - y_k|^2). Returns false if Ceres
  // finds no usable solution (non-finite values). CHECKs: trained, K >= 1, sizes,
  // vertex indices in [0, N).
  bool FitLatent(const std::vector<int>& vertices, const Eigen::Matrix3Xd& positions,
                 const Eigen::VectorXd& initial, const LatentFitOptions& fit, Eigen::VectorXd* z,
                 double* rms) const;

  // The priors' part of FitLatent's objective at latent z (d) for num_points target
  // points (LatentFitter::PriorTerms' latent part):
  //   fit.latent_regularization |z|^2
  //   + (fit.latent_prior / min(num_points, fit.prior_points_cap)) |L^-1 (z - mean)|^2
  // (L L^T and mean: latent_prior()'s covariance and mean; no cap where
  // prior_points_cap <= 0). CHECKs: trained, num_points >= 1, z's size.
  double FitPriorTerm(const Eigen::VectorXd& z, int num_points, const LatentFitOptions& fit) const;

  // The data residuals of FitLatent as a Ceres cost function over one parameter block,
  // z (d): residuals sqrt(1/K) (surface_{v_k}(z) - y_k), 3K of them, vertex after
  // vertex (x y z each); the Jacobian is 3K x d, row-major (Ceres' convention). Holds
  // copies of what it needs (independent of this object's lifetime). The caller owns
  // it. Public for tests. Same CHECKs as FitLatent.
  std::unique_ptr<ceres::CostFunction> NewFitCostFunction(const std::vector<int>& vertices,
                                                          const Eigen::Matrix3Xd& positions) const;

 private:
  SurfaceAutoencoderOptions options_;
  Eigen::Matrix3Xd neutral_;
  std::unique_ptr<Mlp> mlp_;
  Eigen::VectorXd parameters_;
  Eigen::MatrixXd latents_;
  GaussianPrior latent_prior_;
  SurfaceAutoencoderReport report_;
};

}  // namespace aqs

#endif  // AQS_EVAL_SURFACE_AUTOENCODER_H_
