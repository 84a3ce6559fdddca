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
#include "fit/fit_options.h"
#include "fit/fit_target.h"
#include "model/active_model.h"

namespace ceres {
class CostFunction;
}

namespace aqs {

// What a fit returns (LatentFitter::Fit, FitPointCloud; the options: fit/fit_options.h).
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
