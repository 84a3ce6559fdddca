#ifndef AQS_FIT_LATENT_FIT_H_
#define AQS_FIT_LATENT_FIT_H_

#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "diff/equilibrium_differentiator.h"
#include "equilibrium/quasistatic_solver.h"
#include "model/active_model.h"

namespace ceres {
class CostFunction;
}

namespace aqs {

struct LatentFitOptions {
  // Residual sqrt(latent_regularization) z added to the data residuals (the prior the
  // latents were trained with, in the same units: the data term is the weighted mean
  // squared distance over the target points).
  double latent_regularization = 1e-3;
  // Also fit the rigid motion of each bone of the model (6 numbers each: a rotation
  // vector and a translation of the bone's rest position). Otherwise bones stay where
  // set_bone_transforms put them.
  bool fit_bones = true;
  int max_iterations = 50;
  QuasistaticSolverOptions solver;
  int num_threads = 2;
};

// What to fit: K target points, each a point of the model's surface given as a
// barycentric combination of up to three surface vertices (vertices(., k) with weights
// barycentric(., k); a single vertex is (v, v, v) with (1, 0, 0)), and the position it
// should take. Optional per-point weights (empty: all 1).
struct FitTarget {
  Eigen::Matrix3Xi vertices;
  Eigen::Matrix3Xd barycentric;
  Eigen::Matrix3Xd positions;
  Eigen::VectorXd weights;

  int num_points() const { return static_cast<int>(positions.cols()); }
};

// Targets on single surface vertices (markers): vertex v_k at positions.col(k).
FitTarget VertexTarget(const std::vector<int>& vertices, const Eigen::Matrix3Xd& positions);
// All surface vertices at `surface` (3 x num_surface_vertices): a pose with known
// correspondence.
FitTarget FullSurfaceTarget(const Eigen::Matrix3Xd& surface);

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
  bool converged = false;
  std::string message;
};

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
  // Stop when the mean matched distance changes by less than this fraction.
  double relative_tolerance = 1e-3;
};

// Fits the latent (and bone motions) of a trained model to targets with the decoder
// fixed:
//
//   min  (1/sum w) sum_k w_k |p_k(x*(a(z), bones)) - y_k|^2 + latent_regularization |z|^2,
//
// as a Ceres least-squares problem (Levenberg-Marquardt over the latent_dim numbers of
// z, plus 6 per bone) whose Jacobian comes from implicit differentiation: with one
// stiffness factorization, latent_dim Jacobian-vector products through da/dz (the
// decoder's forward-mode Jacobian) and 6 per bone through the fixed vertices it moves.
// Equilibria are warm-started from the last one. The model must outlive the fitter.
class LatentFitter {
 public:
  LatentFitter(const ActiveModel& model, const LatentFitOptions& options);
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

  // Fits from latent `initial` (latent_dim) and the current bone transforms. Returns
  // false with *error if the equilibrium cannot be computed at the start.
  bool Fit(const FitTarget& target, const Eigen::VectorXd& initial, LatentFitResult* result,
           std::string* error);

  // Fits to a point cloud (3 x M, in the model's frame) by re-matched closest points.
  bool FitPointCloud(const Eigen::Matrix3Xd& points, const PointCloudFitOptions& cloud_options,
                     const Eigen::VectorXd& initial, LatentFitResult* result, std::string* error);

  // The equilibrium and surface for latent z with the current bone transforms.
  bool Simulate(const Eigen::VectorXd& z, Eigen::Matrix3Xd* state, Eigen::Matrix3Xd* surface,
                std::string* error);

  // The report of Simulate's last equilibrium solve.
  const QuasistaticSolveReport& last_simulate_report() const { return last_simulate_report_; }

  // The mean of the training latents (a neutral starting point).
  Eigen::VectorXd MeanLatent() const;

  // The data cost Fit minimizes, as a Ceres cost function (parameter blocks: z, then 6
  // numbers per bone if bones are fitted), for derivative tests. `target` must outlive
  // it; it uses this fitter's solver.
  ceres::CostFunction* NewCostFunction(const FitTarget& target);

 private:
  class FitCost;
  const ActiveModel& model_;
  LatentFitOptions options_;
  std::unique_ptr<ShapeTargetModel> physics_;
  std::unique_ptr<QuasistaticSolver> solver_;
  std::unique_ptr<EquilibriumDifferentiator> differentiator_;
  std::vector<RigidTransform> bones_;
  QuasistaticSolveReport last_simulate_report_;
  // Where equilibrium solves start (see set_start_state).
  Eigen::Matrix3Xd accepted_state_;
};

// A bone transform from its 6 fit parameters (rotation vector, translation) and back.
RigidTransform BoneTransformFromParameters(const double* parameters);
void BoneTransformToParameters(const RigidTransform& transform, double* parameters);

}  // namespace aqs

#endif  // AQS_FIT_LATENT_FIT_H_
