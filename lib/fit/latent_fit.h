#ifndef AQS_FIT_LATENT_FIT_H_
#define AQS_FIT_LATENT_FIT_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <ceres/problem.h>

#include "diff/equilibrium_differentiator.h"
#include "equilibrium/quasistatic_solver.h"
#include "fit/bone_parameters.h"
#include "fit/fit_target.h"
#include "model/active_model.h"

namespace ceres {
class CostFunction;
}

namespace aqs {

struct LatentFitOptions {
  // The priors of the model (ActiveModel::fit_prior, learned from its training poses if
  // it has none): Gaussians over the latent and over each bone's 6 motion parameters,
  // centred on the neutral. Each adds residuals sqrt(weight / W) L^-1 (x - mean) to the
  // data residuals sqrt(w_k / W) (p_k - y_k), W = sum_k w_k (the number of target
  // points for markers, poses and scans; with matching rounds, the matched weight). The
  // weights are squared lengths in model units: the squared distance per target point
  // that one standard deviation of the prior is worth. So the priors weigh less against many
  // points than against a few markers, as a Bayesian posterior with that per-point
  // noise variance would (up to prior_points_cap). 0: off.
  // The bone prior's default, 0.01, was chosen on the demo's fit benchmark (docs/fitting.md,
  // 2026-12-01 third session): against 0.03 it tracks the marker sequence at 0.099 instead
  // of 0.137 and leaves the marker mixes, full-correspondence fits and scans within 1%.
  // The latent prior's default stays 0.03: at 0.01 the full face (latent 16) fits 20 / 60
  // markers closer (validation mixes 0.0949 -> 0.0802 / 0.0549 -> 0.0486) and the demo
  // (latent 8) as closely, but the demo's fit of ICT's mouthClose (lips pushed through
  // each other) then needs 263 s of contact instead of 11. Scans have their own weight
  // (PointCloudFitOptions::latent_prior; docs/fitting.md, "The latent prior's weight").
  double latent_prior = 0.03;
  double bone_prior = 0.01;
  // W in the priors' weights is at most this many points: target points are not
  // independent observations (the model's errors are correlated over the surface), so
  // thousands of scan or pose points must not make the priors vanish. <= 0: no cap.
  double prior_points_cap = 200;
  // Legacy isotropic prior: residual sqrt(latent_regularization) z (not scaled by the
  // number of points; what the latents were trained with). 0: off.
  double latent_regularization = 0.0;
  // Also fit the rigid motion of each bone of the model (6 numbers each: a rotation
  // vector and a translation of the bone's rest position). Otherwise bones stay where
  // set_bone_transforms put them.
  bool fit_bones = true;
  int max_iterations = 50;
  // Levenberg-Marquardt stops when the cost changes by less than this fraction in an
  // iteration (Ceres' function_tolerance) or the step is below parameter_tolerance
  // relative to the parameters.
  double function_tolerance = 1e-4;
  double parameter_tolerance = 1e-10;
  // A second start against the local minima of dense targets (poses with known
  // correspondence): Fit fits a point-to-point target of more than twice this many
  // points directly and also, from the same start, first to this many of its points
  // (FarthestPointSubset, target_subset.h) and then to all of them, and keeps the fit of
  // the smaller objective. The jaw's motion makes the objective non-convex; sparser data
  // can lead around a minimum that all points hold. On the demo's 40 benchmark mixes,
  // 200 points changed one fit (0.160 -> 0.096 cm) at three times the factorizations
  // (docs/fitting.md), so it is off by default. 0: directly only.
  int coarse_points = 0;
  // Also estimate how well the data determine the fit (LatentFitResult's
  // parameter_covariance, surface_std): the covariance of the fitted parameters, from
  // ceres::Covariance at the result, as the posterior of Gaussian data noise whose
  // per-residual variance is the fit's own (sigma^2 = sum_k w_k |p_k - y_k|^2 /
  // (residuals - parameters)), carried to each surface vertex through dx*/dparameters.
  // Costs one covariance of latent_dim + 6 per bone parameters; the products are the
  // last Jacobian's.
  bool uncertainty = false;
  QuasistaticSolverOptions solver;
  int num_threads = 2;

  // Checks every field (fit/fit_options.cc); false with *error naming the first bad one.
  bool Validate(std::string* error) const;
  // What shapes a fit's result, as text (every field but num_threads; the solver's
  // QuasistaticSolverOptions::KeyText): the key of stored fits (aqs_evaluate's). A new
  // field that changes results belongs here.
  std::string KeyText() const;
};

struct LatentFitResult {
  Eigen::VectorXd latent;
  std::vector<RigidTransform> bones;  // the bones' motion (fitted or as set)
  Eigen::Matrix3Xd state;    // the equilibrium (3 x num_vertices)
  Eigen::Matrix3Xd surface;  // the simulated surface (3 x num_surface_vertices)
  // Distances between the fitted surface points and the targets (for point clouds:
  // over the points with non-zero weight in the last matching).
  double rms_error = 0.0, mean_error = 0.0, max_error = 0.0;
  int iterations = 0;  // Levenberg-Marquardt iterations (summed over re-matchings)
  int used_points = 0;  // points with non-zero weight
  // Point clouds: the fraction of scan points within max_distance of the fitted surface
  // (mean_error etc. are their matched distances).
  double matched_fraction = 1.0;
  // Point clouds: the mean matched distance at the start of each matching round, and
  // after the last round's solve where the rounds ran out.
  std::vector<double> round_distances;
  // Point clouds with landmarks (PointCloudFitOptions::landmarks): their mean distance
  // to the fitted surface points (0 without landmarks).
  double landmark_mean_error = 0.0;
  // With LatentFitOptions::uncertainty (else empty): the covariance of the fitted
  // parameters (latent, then 6 per fitted bone; P x P, in model units) and, per surface
  // vertex, the standard deviation of its position it implies, sqrt(trace(G_v C G_v^T))
  // with G_v = d(vertex v)/d(parameters) (num_surface_vertices). noise_sigma: the
  // per-residual standard deviation estimated from the fit's residuals. Where the
  // covariance cannot be computed, both stay empty and uncertainty_message says why.
  Eigen::MatrixXd parameter_covariance;
  Eigen::VectorXd surface_std;
  double noise_sigma = 0.0;
  std::string uncertainty_message;
  std::string start;  // where the fit started (ChooseStart), "" if not chosen
  // With LatentFitOptions::coarse_points: whether the second start ran, and whether the
  // fit kept is the one through the subset of points.
  bool second_start_ran = false, second_start_kept = false;
  // With FitStartOptions::retry_from_given (FitFromChosenStart): why the fit was run
  // again from the given start ("" : it was not), and whether that fit was kept.
  std::string retry_reason;
  bool retry_kept = false;
  // Where the time went: equilibrium solves (count, stiffness factorizations, seconds)
  // and Jacobians (count, seconds: one factorization and the products each).
  int solves = 0, solve_factorizations = 0, jacobians = 0;
  double solve_seconds = 0.0, jacobian_seconds = 0.0;
  // Jacobians from the regularized stiffness, where the exact one could not be factorized
  // (PrepareExactOrShifted: a free mesh piece without surface, a singular state).
  int shifted_jacobians = 0;
  bool converged = false;
  // Levenberg-Marquardt stopped with a failure (Ceres' FAILURE: e.g. the residuals or
  // Jacobian could not be evaluated at the start), not for an iteration limit.
  bool failed = false;
  std::string message;
};

// Adds other's work counters (iterations, solves, solve factorizations and seconds,
// Jacobians and their seconds) to *result's: a result that stands for several fits.
void AddFitCounters(const LatentFitResult& other, LatentFitResult* result);

// Options of point-cloud fitting (scans without correspondence).
struct PointCloudFitOptions {
  // Matching/fitting rounds: each matches every scan point to the closest point of the
  // current simulated surface, then refits with those correspondences fixed.
  int max_rounds = 8;
  int iterations_per_round = 6;
  // Scan points farther than this from the surface are ignored in that round (outliers,
  // parts the model does not cover). <= 0: no cap.
  double max_distance = 1.0;
  // Cauchy robust weights w = 1 / (1 + (d / robust_scale)^2) (iteratively reweighted
  // least squares); <= 0: plain least squares.
  double robust_scale = 0.2;
  // Stop when the mean matched distance changes by less than this fraction; rounds that
  // run out converge when the last round's solve changed it by less (one more matching).
  double relative_tolerance = 1e-3;
  // Point-to-plane residuals (FitTarget::normals, the matched triangle's normal) with
  // this weight on the tangential part; >= 1: point-to-point. (Matching rounds only.)
  double tangential_weight = 0.2;
  // One Levenberg-Marquardt solve whose residuals are the scan points' robust
  // distances to the surface, re-matched at every evaluation (see FitPointCloud),
  // instead of matching rounds with fixed correspondences.
  bool rematch_every_evaluation = true;
  // Landmarks: points of the scan whose place on the model's surface is known (e.g. the
  // eye and mouth corners a face tracker finds in the scan's image), fitted together
  // with the scan in both modes. Distances to a surface do not see motion along it (a
  // mouth that slides sideways); landmarks do. The objective adds
  //   landmark_weight (1/sum w) sum_k w_k |p_k - y_k|^2
  // (the target's points and weights), so with weight 1 the landmarks' mean squared
  // distance counts as much as the scan's. Empty (no points): none. The default was
  // chosen on the demo's validation scans with 10 landmarks of 0.1 cm noise, by the scans
  // within 1.2x of the fit with correspondence: 14 of 20 without landmarks; 14, 15, 10,
  // 6 and 3 with weights 0.01, 0.03, 0.1, 0.3 and 1 (docs/fitting.md). Landmarks are
  // where the model errs most, and a fit that holds them tightly bends the rest of the
  // face to them (weight 1 is worse even with exact landmarks). Many precise landmarks
  // are another matter: 60 markers the scan shows (0.02 cm noise) fit best at weight 1
  // (19 of 20 validation scans within 1.2x on both the demo and the full face).
  FitTarget landmarks;
  double landmark_weight = 0.03;
  // The bone prior of scan fits: its weight (< 0: LatentFitOptions::bone_prior's), and
  // it is centred on the bones the fit starts from (the training pose ChooseStart picks,
  // the given start, or a sequence's previous frame) instead of the prior's centre: the
  // training poses' bone motions as the modes of the prior, the start's mode the one
  // that holds. The start itself is chosen without it. A scan sees one side, and the
  // jaw's motion shows most where it does not look (under the chin): on the demo's
  // validation scans, 16 of 20 within 1.2x of the fit with correspondence (18 with
  // landmarks) against 14 (15) with the other fits' prior (docs/fitting.md). Centred on
  // the prior's centre, weight 0.1 held a scan's wide-open jaw shut (test mix_007).
  double bone_prior = 0.1;
  // The latent prior's weight in scan fits (< 0: LatentFitOptions::latent_prior's). A
  // scan's distances stay small wherever the surface can slide along it, so the prior
  // weighs more against a scan than against a pose or markers, and held scans near the
  // prior's centre. Chosen on the validation scans by those within 1.2x of the fit with
  // correspondence (demo + full face, without / with 10 landmarks): 0.03 (the other
  // fits') 16 + 1 / 18 + 2 of 20, 0.01 16 + 6 / 18 + 8, 0.003 15 + 9 / 16 + 9; the full
  // face's scans 0.0815 -> 0.0628 at 0.01, the demo's 0.0935 -> 0.0940 (docs/fitting.md).
  double latent_prior = 0.01;

  // Checks every field (fit/fit_options.cc); false with *error naming the first bad one.
  bool Validate(std::string* error) const;
  // Every number above that shapes a scan fit's result, as one line of text (the
  // landmarks, data rather than options, are not in it): the key of stored fits (a
  // sequence's key.txt). A new field that changes results belongs here.
  std::string KeyText() const;
};

// The smallest robust_scale and max_distance a point-cloud fit takes (when on, > 0), in
// model sizes (ModelSize: the diagonal of the neutral's bounding box). Below, every scan
// point weighs alike and next to nothing (robust_scale 1e-300: the fit stays where it
// starts), or none is matched.
constexpr double kMinPointScaleInModelSizes = 1e-6;

// Checks options.robust_scale and options.max_distance against a model of size
// `model_size` (model units): each 0 (off) or at least kMinPointScaleInModelSizes model
// sizes. Returns false with *error naming the field ("points.robust_scale",
// "points.max_distance"), its value and the smallest it takes. Validate() checks the
// rest, without the model.
bool CheckPointCloudScales(const PointCloudFitOptions& options, double model_size,
                           std::string* error);

// Where fits start (LatentFitter::ChooseStart).
struct FitStartOptions {
  // Consider the training poses with a stored equilibrium (their latent, bone motions
  // and equilibrium) besides the given start, and start from whichever has the
  // smallest objective (the fit's data term plus priors; for scans, with the matching
  // of the first round).
  bool training_poses = true;
  // FitFromChosenStart (fit/chosen_start_fit.h): a fit from a training pose that fails,
  // does not converge, or ends with a bone farther from the prior's centre than any
  // training pose's and than one standard deviation (Mahalanobis distance under the bone
  // prior) is fitted again from the given start, and the fit of the smaller objective
  // kept. On the demo's surface-
  // latent model, two full-correspondence fits from jawOpen went on to a 25 degree jaw
  // (0.231 and 0.160 cm, 224 and 142 s), where fits from the given start reach 0.101 and
  // 0.053 in 2 s (docs/fitting.md).
  bool retry_from_given = true;
  // The given start of aqs_fit and the benchmark: the mean of the training latents
  // (what fits did before priors) instead of the latent prior's centre.
  bool mean_latent = false;
};

// Fits the latent (and bone motions) of a trained model to targets with the decoder
// fixed:
//
//   min  (1/sum w) sum_k w_k |p_k(x*(a(z), bones)) - y_k|^2 + latent_regularization |z|^2
//        + (latent_prior / W') |L_z^-1 (z - z_0)|^2
//        + (bone_prior / W') sum_b |L_b^-1 (b - b_0)|^2
//
// (the Gaussian priors of the model's FitPrior, W' the capped point count:
// AddPriorBlocks, docs/fitting.md "What a fit minimizes"; scans replace the data term
// by robust closest-point distances) as a Ceres least-squares problem
// (Levenberg-Marquardt over the latent_dim numbers of z, plus 6 per bone) whose
// Jacobian comes from implicit differentiation: with one
// stiffness factorization, latent_dim Jacobian-vector products through da/dz (the
// decoder's forward-mode Jacobian) and 6 per bone through the fixed vertices it moves.
// Equilibria are warm-started from the last one. The model must outlive the fitter, and
// the options must be valid (LatentFitOptions::Validate; CHECKed).
class LatentFitter {
 public:
  LatentFitter(const ActiveModel& model, const LatentFitOptions& options);
  // It keeps a reference to the model: a temporary one does not compile.
  LatentFitter(ActiveModel&& model, const LatentFitOptions& options) = delete;
  ~LatentFitter();

  // Bone motions used by Simulate, and the start of fits (default: rest).
  void set_bone_transforms(const std::vector<RigidTransform>& transforms);
  const std::vector<RigidTransform>& bone_transforms() const { return bones_; }
  // The state (3 x num_vertices) the next equilibrium solve starts from (default: the
  // rest shape, then the equilibrium of the last simulated or accepted fit point; trial
  // points of a fit that are rejected never become starts). The energy is not convex: a
  // training pose's stored equilibrium (ActiveModel::states) is the branch training saw.
  void set_start_state(const Eigen::Matrix3Xd& state);
  // The same from training pose p's stored equilibrium, if the model has one.
  void StartFromTrainingPose(int p);
  // A temporal prior for the frames of a tracked sequence: every later fit (Fit and
  // FitPointCloud) adds
  //   (weight / W') |L_z^-1 (z - latent)|^2 + (weight / W') sum_b |L_b^-1 (b - bones_b)|^2
  // (the bone part only where bones are fitted), the model's latent and bone priors'
  // whitenings L^-1 centred on the given latent (latent_dim) and bone motions (one per
  // bone: the previous frame's result), W' as for the priors. It pulls a frame toward its
  // predecessor by as many standard deviations of the training spread as the other priors
  // pull toward the neutral, and damps the jitter that marker noise gives a track.
  // weight <= 0 switches it off (the default).
  void SetTemporalPrior(double weight, const Eigen::VectorXd& latent,
                        const std::vector<RigidTransform>& bones);
  // The next equilibrium solve factorizes afresh instead of reusing, by CG, the factor
  // of the last one (StiffnessFactorization::RequestRefresh): for a fitter that moves on
  // to an unrelated target, so that its result does not depend on what it fitted before.
  void ForgetFactor();

  // Fits from latent `initial` (latent_dim) and the current bone transforms (and, for
  // dense targets, a coarse-to-fine second start: LatentFitOptions::coarse_points; the
  // result's counters then sum both fits). Returns false with *error if the equilibrium
  // cannot be computed at the start or at the end; result's latent, bones, state and
  // surface are then those of the unconverged equilibrium there, for inspection.
  bool Fit(const FitTarget& target, const Eigen::VectorXd& initial, LatentFitResult* result,
           std::string* error);

  // Fits to a point cloud (3 x M, in the model's frame) by re-matched closest points:
  // with rematch_every_evaluation, minimizes
  //   (1/M) sum_i R(min(d_i, max_distance))^2 + landmarks + priors,
  //   R(d) = d / sqrt(1 + (d/s)^2),
  // d_i the distance of scan point i to the simulated surface (its closest point found
  // at every evaluation, s = robust_scale: the Cauchy-weighted squared distance of the
  // rounds); otherwise rounds of matching, then fitting with fixed correspondences. The
  // landmark term is PointCloudFitOptions::landmarks' (none if it has no points).
  // Returns false with *error as Fit does, and also when, without landmarks, fewer than 3
  // scan points lie within max_distance of the fitted surface (nothing held the fit).
  bool FitPointCloud(const Eigen::Matrix3Xd& points, const PointCloudFitOptions& cloud_options,
                     const Eigen::VectorXd& initial, LatentFitResult* result, std::string* error);

  // The equilibrium and surface for latent z with the current bone transforms. Returns
  // false with *error if the solve did not converge (from the start state, then from
  // rest); *state and *surface then hold the state it ended in, for inspection.
  bool Simulate(const Eigen::VectorXd& z, Eigen::Matrix3Xd* state, Eigen::Matrix3Xd* surface,
                std::string* error);

  // The report of Simulate's last equilibrium solve.
  const QuasistaticSolveReport& last_simulate_report() const { return last_simulate_report_; }

  // Non-zeros of the Cholesky factor of the model's stiffness (runs CHOLMOD's symbolic
  // analysis if no factorization ran yet): what BlasThreadsForFactor (util/blas.h) takes.
  double FactorNonzeros();

  // The mean of the training latents.
  Eigen::VectorXd MeanLatent() const;
  // The centre of the latent prior (the neutral's latent when the neutral is a
  // training pose): the default start of fits.
  Eigen::VectorXd PriorLatent() const { return prior_.latent.mean; }
  const FitPrior& prior() const { return prior_; }

  // Chooses the start of a fit to `target` (or, with a non-null `points`, to that point
  // cloud): among latent *z with the current bone transforms and start state, and (with
  // options.training_poses) each training pose's latent, bones and stored equilibrium
  // (without LatentFitOptions::fit_bones, only the poses whose bone motions are the
  // current ones: bones not fitted stay where they were set), the one with the smallest
  // objective. Sets the bones and start state, *z and
  // *name ("given" or the pose's name). Returns false with *error if the given start
  // cannot be simulated and no training pose is available.
  // The work of the last ChooseStart (LatentFitResult's solves ... jacobian_seconds: the
  // given start's solve; a training pose's costs none), which a fit's counters leave
  // out (FitFromChosenStart adds it to its result).
  const LatentFitResult& start_choice_work() const { return start_choice_work_; }
  bool ChooseStart(const FitTarget* target, const Eigen::Matrix3Xd* points,
                   const PointCloudFitOptions& cloud_options, const FitStartOptions& options,
                   Eigen::VectorXd* z, std::string* name, std::string* error);

  // The objective of Fit at a simulated surface (3 x num_surface_vertices), latent z
  // and the current bone transforms: data term plus priors.
  double Objective(const FitTarget& target, const Eigen::Matrix3Xd& surface,
                   const Eigen::VectorXd& z) const;
  // What ChooseStart compares: Objective for a target (non-null `target`), or for a
  // point cloud (non-null `points`, 3 x M) what its fit minimizes at `surface` (with
  // rematch_every_evaluation the robust closest-point distances, CloudDataTerm; with
  // matching rounds the target of the matching it induces) with the scan's latent prior
  // and landmark term, without the bone prior (see PointCloudFitOptions::bone_prior);
  // infinity if fewer than 3 points lie within max_distance. At the current bone
  // transforms.
  double StartObjective(const FitTarget* target, const Eigen::Matrix3Xd* points,
                        const PointCloudFitOptions& cloud_options, const Eigen::Matrix3Xd& surface,
                        const Eigen::VectorXd& z) const;

  const ActiveModel& model() const { return model_; }
  // Where the next equilibrium solve starts (see set_start_state).
  const Eigen::Matrix3Xd& start_state() const { return accepted_state_; }

  // The data cost Fit minimizes, as a Ceres cost function (parameter blocks: z, then 6
  // numbers per bone if bones are fitted), for derivative tests. `target` must outlive
  // it; it uses this fitter's solver. Each evaluation solves warm from the current start
  // state (set_start_state), which it never moves: its residuals and Jacobians are a
  // function of the parameters alone.
  ceres::CostFunction* NewCostFunction(const FitTarget& target);
  // The same for a point cloud's re-matched robust distances (`points` must outlive it).
  ceres::CostFunction* NewCloudCostFunction(const Eigen::Matrix3Xd& points,
                                            const PointCloudFitOptions& options);

 private:
  class FitEquilibrium;
  class FitCost;
  // Objective with the priors weighed by `latent_prior` and `bone_prior` instead of the
  // options'.
  double ObjectiveWithPriors(const FitTarget& target, const Eigen::Matrix3Xd& surface,
                             const Eigen::VectorXd& z, double latent_prior,
                             double bone_prior) const;
  // The priors' part of the objective at latent z and the current bone transforms
  // (latent_regularization |z|^2, the Gaussian priors and the temporal prior over
  // prior_points points).
  double PriorTerms(const Eigen::VectorXd& z, double latent_prior, double bone_prior,
                    double prior_points) const;
  // The latent prior's weight in a scan fit with these options.
  double ScanLatentPrior(const PointCloudFitOptions& cloud_options) const {
    return cloud_options.latent_prior >= 0 ? cloud_options.latent_prior : options_.latent_prior;
  }
  // LatentFitResult's uncertainty fields at the solved `problem`'s point (blocks: z,
  // then the fitted bones). The noise comes from the data's residual block `data_block`
  // (cost `data_cost`, scaled by 1/sqrt(data_weight) per unit weight) alone, over the
  // residuals the fit uses (not a scan's points beyond max_distance, nor a matching
  // round's unmatched points); landmarks and priors shape the covariance only.
  void EstimateUncertainty(ceres::Problem* problem, const std::vector<double*>& blocks,
                           ceres::ResidualBlockId data_block, const FitCost* data_cost,
                           double data_weight, FitEquilibrium* equilibrium,
                           LatentFitResult* result);
  // Adds the priors' residual blocks on *z and, where given (the bones are fitted), on
  // *bone_parameters (6 per bone): latent_regularization |z|^2, and the Gaussian priors
  // of the latent and of each bone, weighed per point over `prior_points` points (a
  // scan's by its own weights, its bone prior centred on the bones it started from), and
  // the temporal prior if one is set.
  void AddPriorBlocks(ceres::Problem* problem, double prior_points,
                      std::vector<Eigen::Matrix<double, 6, 1>>* bone_parameters,
                      Eigen::VectorXd* z) const;
  // One Levenberg-Marquardt fit from `initial` (what Fit does without a second start).
  bool FitFrom(const FitTarget& target, const Eigen::VectorXd& initial, LatentFitResult* result,
               std::string* error);
  const ActiveModel& model_;
  LatentFitOptions options_;
  std::unique_ptr<ShapeTargetModel> physics_;
  std::unique_ptr<QuasistaticSolver> solver_;
  std::unique_ptr<EquilibriumDifferentiator> differentiator_;
  std::vector<RigidTransform> bones_;
  QuasistaticSolveReport last_simulate_report_;
  FitPrior prior_;
  // Counters of the current fit (LatentFitResult's solves ... jacobian_seconds), and
  // those of the last start choice.
  LatentFitResult stats_;
  LatentFitResult start_choice_work_;
  // Set by FitPointCloud while it fits (both modes; nullptr: not a scan fit): its
  // options (landmarks, bone prior), and each bone's 6 parameters at its start, where
  // its bone prior is centred.
  const PointCloudFitOptions* cloud_options_ = nullptr;
  std::vector<Eigen::Matrix<double, 6, 1>> cloud_bone_centres_;
  // Set by FitPointCloud while FitFrom solves the re-matched closest-point problem.
  const Eigen::Matrix3Xd* direct_cloud_ = nullptr;
  // Where equilibrium solves start (see set_start_state).
  Eigen::Matrix3Xd accepted_state_;
  // SetTemporalPrior's weight (<= 0: none), latent and bone parameters (6 per bone).
  double temporal_weight_ = 0.0;
  Eigen::VectorXd temporal_latent_;
  std::vector<Eigen::Matrix<double, 6, 1>> temporal_bones_;
};

}  // namespace aqs

#endif  // AQS_FIT_LATENT_FIT_H_
