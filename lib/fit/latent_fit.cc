// LatentFitter: construction, simulation, and the fits (targets with correspondence and
// point clouds). Its Ceres pieces are fit/fit_equilibrium.h and fit/fit_cost.h; the
// start choice is start_choice.cc, the uncertainty fit_uncertainty.cc.

#include "fit/latent_fit.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <utility>

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>
#include <ceres/problem.h>
#include <ceres/solver.h>
#include <glog/logging.h>

#include "fit/fit_cost.h"
#include "fit/fit_equilibrium.h"
#include "fit/gaussian_prior_cost.h"
#include "fit/latent_prior.h"
#include "fit/point_cloud_matching.h"
#include "fit/target_subset.h"
#include "geometry/embedding.h"
#include "geometry/triangle_bvh.h"
#include "util/fault_injection.h"
#include "util/wall_timer.h"

namespace aqs {

LatentFitter::LatentFitter(const ActiveModel& model, const LatentFitOptions& options)
    : model_(model), options_(options), bones_(RestBoneTransforms(model)),
      accepted_state_(model.mesh.vertices) {
  CHECK(model.decoder) << "latent fitting needs a trained model";
  std::string invalid;
  CHECK(options.Validate(&invalid)) << "LatentFitOptions: " << invalid;
  prior_ = model.fit_prior.empty() ? LearnFitPrior(model) : model.fit_prior;
  CHECK_EQ(prior_.latent.size(), model.latent_dim());
  CHECK_EQ(prior_.bones.size(), model.bones.size());
  physics_ = std::make_unique<ShapeTargetModel>(model.mesh, model.mu);
  QuasistaticSolverOptions solver_options = options.solver;
  solver_options.num_threads = options.num_threads;
  solver_ = std::make_unique<QuasistaticSolver>(*physics_, ModelBoundaryConditions(model, bones_),
                                                solver_options);
  differentiator_ = std::make_unique<EquilibriumDifferentiator>(
      solver_->stiffness_factorization(), EquilibriumDifferentiatorOptions{options.num_threads});
}

LatentFitter::~LatentFitter() = default;

void LatentFitter::set_bone_transforms(const std::vector<RigidTransform>& transforms) {
  CHECK_EQ(transforms.size(), model_.bones.size());
  bones_ = transforms;
  solver_->SetFixedPositions(ModelBoundaryConditions(model_, bones_).positions);
}

void LatentFitter::ForgetFactor() { solver_->stiffness_factorization()->RequestRefresh(); }

double LatentFitter::FactorNonzeros() {
  StiffnessFactorization* factorization = solver_->stiffness_factorization();
  if (factorization->cholesky().factor_nonzeros() == 0) factorization->Analyze();
  return factorization->cholesky().factor_nonzeros();
}

Eigen::VectorXd LatentFitter::MeanLatent() const { return model_.latents.rowwise().mean(); }

ceres::CostFunction* LatentFitter::NewCostFunction(const FitTarget& target) {
  auto equilibrium =
      std::make_unique<FitEquilibrium>(this, options_.fit_bones && !model_.bones.empty());
  auto* cost = new FitCost(this, equilibrium.get(), target);
  cost->Own(std::move(equilibrium));
  return cost;
}

ceres::CostFunction* LatentFitter::NewCloudCostFunction(const Eigen::Matrix3Xd& points,
                                                       const PointCloudFitOptions& options) {
  auto equilibrium =
      std::make_unique<FitEquilibrium>(this, options_.fit_bones && !model_.bones.empty());
  auto* cost = new FitCost(this, equilibrium.get(), points, options);
  cost->Own(std::move(equilibrium));
  return cost;
}

void LatentFitter::set_start_state(const Eigen::Matrix3Xd& state) {
  CHECK_EQ(state.cols(), model_.mesh.num_vertices());
  accepted_state_ = state;
}

void LatentFitter::StartFromTrainingPose(int p) {
  CHECK(p >= 0 && p < model_.num_poses());
  if (p < static_cast<int>(model_.states.size()) &&
      model_.states[p].cols() == model_.mesh.num_vertices()) {
    set_start_state(model_.states[p]);
  }
}

void LatentFitter::SetTemporalPrior(double weight, const Eigen::VectorXd& latent,
                                    const std::vector<RigidTransform>& bones) {
  CHECK_EQ(latent.size(), model_.latent_dim());
  CHECK_EQ(bones.size(), model_.bones.size());
  temporal_weight_ = weight;
  temporal_latent_ = latent;
  temporal_bones_.assign(bones.size(), Eigen::Matrix<double, 6, 1>::Zero());
  for (size_t b = 0; b < bones.size(); ++b) {
    BoneTransformToParameters(bones[b], temporal_bones_[b].data());
  }
}

bool LatentFitter::Simulate(const Eigen::VectorXd& z, Eigen::Matrix3Xd* state,
                            Eigen::Matrix3Xd* surface, std::string* error) {
  ActuationMatrix a;
  DecoderWorkspace workspace;
  model_.decoder->Decode(model_.decoder_params.data(), z, &a, &workspace);
  solver_->SetPositions(accepted_state_);
  solver_->SetFixedPositions(ModelBoundaryConditions(model_, bones_).positions);
  solver_->actuation() = a;
  WallTimer timer;
  QuasistaticSolveReport report = solver_->Solve();
  stats_.solves += 1;
  stats_.solve_factorizations += report.factorizations;
  if (!report.converged) {  // once more from rest
    solver_->SetPositions(model_.mesh.vertices);
    report = solver_->Solve();
    stats_.solves += 1;
    stats_.solve_factorizations += report.factorizations;
  }
  last_simulate_report_ = report;
  stats_.solve_seconds += timer.Seconds();
  if (!report.converged) {
    *error = "the equilibrium was not reached: " + report.Summary();
    *state = solver_->positions();
    *surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, *state);
    return false;
  }
  *state = solver_->positions();
  accepted_state_ = *state;
  *surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, *state);
  return true;
}

void AddFitCounters(const LatentFitResult& other, LatentFitResult* result) {
  result->iterations += other.iterations;
  result->solves += other.solves;
  result->solve_factorizations += other.solve_factorizations;
  result->solve_seconds += other.solve_seconds;
  result->jacobians += other.jacobians;
  result->jacobian_seconds += other.jacobian_seconds;
  result->shifted_jacobians += other.shifted_jacobians;
}

bool LatentFitter::Fit(const FitTarget& target, const Eigen::VectorXd& initial,
                       LatentFitResult* result, std::string* error) {
  if (direct_cloud_ == nullptr &&
      !ValidateFitTarget(target, model_.num_surface_vertices(), error)) {
    return false;
  }
  const int coarse = options_.coarse_points;
  if (direct_cloud_ != nullptr || coarse <= 0 || target.num_points() <= 2 * coarse ||
      target.normals.cols() > 0) {
    return FitFrom(target, initial, result, error);
  }
  const std::vector<RigidTransform> start_bones = bones_;
  const Eigen::Matrix3Xd start_state = accepted_state_;
  if (!FitFrom(target, initial, result, error)) return false;
  const LatentFitResult direct = *result;
  const double direct_objective = Objective(target, direct.surface, direct.latent);
  // The second start: the same start, a sparse subset of the points, then all of them.
  bones_ = start_bones;
  accepted_state_ = start_state;
  LatentFitResult sparse, fine;
  std::string second_error;
  const bool second_ok =
      FitFrom(FarthestPointSubset(target, coarse), initial, &sparse, &second_error) &&
      !sparse.failed && FitFrom(target, sparse.latent, &fine, &second_error) && !fine.failed;
  const bool second_better =
      second_ok && Objective(target, fine.surface, fine.latent) < direct_objective;
  *result = second_better ? fine : direct;
  // The counters of every fit that ran (a failed second start counts what it did).
  AddFitCounters(second_better ? direct : fine, result);
  AddFitCounters(sparse, result);
  result->second_start_ran = true;
  result->second_start_kept = second_better;
  bones_ = result->bones;
  accepted_state_ = result->state;
  return true;
}

namespace {

// A fit's point, as it ends: latent, bone motions, equilibrium and surface.
void SetResultPoint(const Eigen::VectorXd& z, const std::vector<RigidTransform>& bones,
                    const Eigen::Matrix3Xd& state, const Eigen::Matrix3Xd& surface,
                    LatentFitResult* result) {
  result->latent = z;
  result->bones = bones;
  result->state = state;
  result->surface = surface;
}

// Ceres' Levenberg-Marquardt for a fit: dense QR (a latent and a few bones' parameters),
// the options' iterations and tolerances.
ceres::Solver::Options FitSolverOptions(const LatentFitOptions& options) {
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = options.parameter_tolerance;
  solver_options.logging_type = ceres::SILENT;
  return solver_options;
}

// result's used_points, mean, rms and max error: the distances of `target`'s points
// (those of positive weight, or all without weights) to their places on `surface`
// (3 x num_surface_vertices).
void MeasureTargetErrors(const FitTarget& target, const Eigen::Matrix3Xd& surface,
                         LatentFitResult* result) {
  int used = 0;
  double sum = 0, sum_squares = 0, worst = 0;
  for (int i = 0; i < target.num_points(); ++i) {
    if (target.weights.size() > 0 && target.weights[i] <= 0) continue;
    Eigen::Vector3d p = Eigen::Vector3d::Zero();
    for (int c = 0; c < 3; ++c) p += target.barycentric(c, i) * surface.col(target.vertices(c, i));
    const double distance = (p - target.positions.col(i)).norm();
    ++used;
    sum += distance;
    sum_squares += distance * distance;
    worst = std::max(worst, distance);
  }
  result->used_points = used;
  result->mean_error = used > 0 ? sum / used : 0.0;
  result->rms_error = used > 0 ? std::sqrt(sum_squares / used) : 0.0;
  result->max_error = worst;
}

}  // namespace

void LatentFitter::AddPriorBlocks(ceres::Problem* problem, double prior_points,
                                  std::vector<Eigen::Matrix<double, 6, 1>>* bone_parameters,
                                  Eigen::VectorXd* z) const {
  if (options_.latent_regularization > 0) {
    problem->AddResidualBlock(new LatentPrior(static_cast<int>(z->size()),
                                              options_.latent_regularization),
                              nullptr, z->data());
  }
  // Scans weigh the priors by their own weights (PointCloudFitOptions::latent_prior,
  // bone_prior) and centre the bone prior on the bones their fit started from.
  const bool scan = cloud_options_ != nullptr;
  const double latent_prior = scan ? ScanLatentPrior(*cloud_options_) : options_.latent_prior;
  if (latent_prior > 0) {
    problem->AddResidualBlock(new GaussianPriorCost(prior_.latent.mean, prior_.latent.whitening,
                                                    latent_prior / prior_points),
                              nullptr, z->data());
  }
  if (temporal_weight_ > 0) {
    problem->AddResidualBlock(new GaussianPriorCost(temporal_latent_, prior_.latent.whitening,
                                                    temporal_weight_ / prior_points),
                              nullptr, z->data());
    for (size_t b = 0; bone_parameters != nullptr && b < model_.bones.size(); ++b) {
      problem->AddResidualBlock(new GaussianPriorCost(temporal_bones_[b], prior_.bones[b].whitening,
                                                      temporal_weight_ / prior_points),
                                nullptr, (*bone_parameters)[b].data());
    }
  }
  const double bone_prior = scan && cloud_options_->bone_prior >= 0 ? cloud_options_->bone_prior
                                                                    : options_.bone_prior;
  if (bone_parameters == nullptr || bone_prior <= 0) return;
  for (size_t b = 0; b < model_.bones.size(); ++b) {
    const Eigen::VectorXd centre =
        scan ? Eigen::VectorXd(cloud_bone_centres_[b]) : prior_.bones[b].mean;
    problem->AddResidualBlock(new GaussianPriorCost(centre, prior_.bones[b].whitening,
                                                    bone_prior / prior_points),
                              nullptr, (*bone_parameters)[b].data());
  }
}

bool LatentFitter::FitFrom(const FitTarget& target, const Eigen::VectorXd& initial,
                           LatentFitResult* result, std::string* error) {
  const int d = model_.latent_dim();
  CHECK_EQ(initial.size(), d);
  CHECK_EQ(target.vertices.cols(), target.positions.cols());
  CHECK_EQ(target.barycentric.cols(), target.positions.cols());
  Eigen::VectorXd z = initial;
  Eigen::Matrix3Xd state, surface;
  stats_ = LatentFitResult();
  if (!Simulate(z, &state, &surface, error)) {
    *error = "at the initial latent: " + *error;
    SetResultPoint(z, bones_, state, surface, result);
    return false;
  }
  const bool fit_bones = options_.fit_bones && !model_.bones.empty();
  std::vector<Eigen::Matrix<double, 6, 1>> bone_parameters(model_.bones.size());
  for (size_t b = 0; b < model_.bones.size(); ++b) {
    BoneTransformToParameters(bones_[b], bone_parameters[b].data());
  }
  std::vector<double*> blocks = {z.data()};
  if (fit_bones) {
    for (auto& p : bone_parameters) blocks.push_back(p.data());
  }
  // Solves and differentiates before Ceres evaluates the residuals (see FitEquilibrium).
  FitEquilibrium equilibrium(this, fit_bones);
  equilibrium.set_blocks(blocks);
  ceres::Problem::Options problem_options;
  problem_options.evaluation_callback = &equilibrium;
  ceres::Problem problem(problem_options);
  double total_weight = 0.0;
  // W of the data residuals' scaling 1/sqrt(W) (FitCost), for the noise estimate.
  const double data_weight = direct_cloud_ != nullptr ? static_cast<double>(direct_cloud_->cols())
                                                      : TotalWeight(target);
  FitCost* data_cost = nullptr;
  if (direct_cloud_ != nullptr) {
    data_cost = new FitCost(this, &equilibrium, *direct_cloud_, *cloud_options_);
    total_weight = static_cast<double>(direct_cloud_->cols());
    if (options_.prior_points_cap > 0) {
      total_weight = std::min(total_weight, options_.prior_points_cap);
    }
  } else {
    data_cost = new FitCost(this, &equilibrium, target);
    total_weight = PriorPoints(target, options_.prior_points_cap);
  }
  // The data's residual block (the landmarks' and the priors' come after): what the
  // noise is estimated from.
  const ceres::ResidualBlockId data_block = problem.AddResidualBlock(data_cost, nullptr, blocks);
  if (cloud_options_ != nullptr && cloud_options_->landmarks.num_points() > 0 &&
      cloud_options_->landmark_weight > 0) {
    // The scan's landmarks: their mean squared distance, times the weight.
    problem.AddResidualBlock(
        new FitCost(this, &equilibrium, cloud_options_->landmarks),
        new ceres::ScaledLoss(nullptr, cloud_options_->landmark_weight, ceres::TAKE_OWNERSHIP),
        blocks);
  }
  // The parameters, all blocks concatenated (FitEquilibrium's key).
  auto key = [&]() {
    const Eigen::Index bone_count = static_cast<Eigen::Index>(bone_parameters.size());
    Eigen::VectorXd k(z.size() + (fit_bones ? 6 * bone_count : 0));
    k.head(z.size()) = z;
    for (size_t b = 0; fit_bones && b < bone_parameters.size(); ++b) {
      k.segment(z.size() + 6 * static_cast<Eigen::Index>(b), 6) = bone_parameters[b];
    }
    return k;
  };
  equilibrium.Seed(key(), state);  // the start's equilibrium is known
  AddPriorBlocks(&problem, total_weight, fit_bones ? &bone_parameters : nullptr, &z);
  ceres::Solver::Summary summary;
  ceres::Solve(FitSolverOptions(options_), &problem, &summary);
  if (fit_bones) {
    for (size_t b = 0; b < model_.bones.size(); ++b) {
      bones_[b] = BoneTransformFromParameters(bone_parameters[b].data());
    }
  }
  // The final point's equilibrium: the last evaluation's when that was the final point
  // (Ceres ends on an accepted point), else solved again.
  bool simulated = true;
  if (const Eigen::Matrix3Xd* known = equilibrium.StateAt(key())) {
    state = *known;
    accepted_state_ = state;
    surface = EmbeddedPositions(model_.embedding, model_.mesh.tets, state);
  } else {
    simulated = Simulate(z, &state, &surface, error);
  }
  SetResultPoint(z, bones_, state, surface, result);
  if (!simulated) return false;
  result->parameter_covariance.resize(0, 0);
  result->surface_std.resize(0);
  result->noise_sigma = 0.0;
  result->uncertainty_message.clear();
  if (options_.uncertainty && summary.termination_type != ceres::FAILURE) {
    EstimateUncertainty(&problem, blocks, data_block, data_cost, data_weight, &equilibrium,
                        result);
  }
  MeasureTargetErrors(target, surface, result);
  // Iteration 0 is the start; none when the start itself could not be evaluated.
  result->iterations = std::max(0, static_cast<int>(summary.iterations.size()) - 1);
  result->solves = stats_.solves;
  result->solve_factorizations = stats_.solve_factorizations;
  result->solve_seconds = stats_.solve_seconds;
  result->jacobians = stats_.jacobians;
  result->shifted_jacobians = stats_.shifted_jacobians;
  result->jacobian_seconds = stats_.jacobian_seconds;
  result->converged = summary.termination_type == ceres::CONVERGENCE;
  result->failed = summary.termination_type == ceres::FAILURE;
  result->message = summary.message;
  // Ceres says only that an evaluation failed; where the start could not be evaluated,
  // the equilibrium says why.
  if (result->failed && !equilibrium.failure().empty()) {
    result->message += " (" + equilibrium.failure() + ")";
  }
  // As a minimizer that fails (the point it accepted could not be evaluated) for tests.
  if (FailurePoint("latent_fit:minimizer")) {
    result->converged = false;
    result->failed = true;
    result->message = "the minimizer failed (test)";
  }
  return true;
}

bool LatentFitter::FitPointCloud(const Eigen::Matrix3Xd& points,
                                 const PointCloudFitOptions& cloud_options,
                                 const Eigen::VectorXd& initial, LatentFitResult* result,
                                 std::string* error) {
  if (points.cols() < 3) {
    *error = "a point cloud needs at least 3 points";
    return false;
  }
  for (Eigen::Index i = 0; i < points.cols(); ++i) {
    if (!points.col(i).allFinite()) {
      *error = "point " + std::to_string(i) + " of the point cloud is not finite";
      return false;
    }
  }
  if (cloud_options.landmarks.num_points() > 0 &&
      !ValidateFitTarget(cloud_options.landmarks, model_.num_surface_vertices(), error)) {
    *error = "landmarks: " + *error;
    return false;
  }
  Eigen::VectorXd z = initial;
  Eigen::Matrix3Xd state, surface;
  // The matching rounds match the start's surface first; the one solve's FitFrom solves
  // the start itself (and counts it).
  LatentFitResult start_work;  // that solve of the start, which the rounds' work includes
  if (!cloud_options.rematch_every_evaluation) {
    stats_ = LatentFitResult();
    if (!Simulate(z, &state, &surface, error)) {
      SetResultPoint(z, bones_, state, surface, result);
      return false;
    }
    start_work = stats_;
  }
  const Eigen::Matrix3Xi& triangles = model_.neutral.triangles;
  const FitTarget& landmarks = cloud_options.landmarks;
  cloud_options_ = &cloud_options;
  cloud_bone_centres_.assign(bones_.size(), Eigen::Matrix<double, 6, 1>::Zero());
  for (size_t b = 0; b < bones_.size(); ++b) {
    BoneTransformToParameters(bones_[b], cloud_bone_centres_[b].data());
  }
  if (cloud_options.rematch_every_evaluation) {
    // One Levenberg-Marquardt solve of the robust closest-point distances.
    direct_cloud_ = &points;
    const bool ok = FitFrom(FitTarget(), z, result, error);
    direct_cloud_ = nullptr;
    cloud_options_ = nullptr;
    if (!ok) return false;
    result->round_distances.clear();
  } else {
  double previous_mean = -1.0;
  int total_iterations = 0;
  LatentFitResult totals = start_work;
  std::vector<double> round_distances;
  LatentFitOptions saved = options_;
  options_.max_iterations = cloud_options.iterations_per_round;
  bool ok = true;
  // The rounds' own convergence (the mean distance settled), not that of the last
  // round's solve, which iterations_per_round caps.
  bool rounds_converged = false;
  for (int round = 0; round < cloud_options.max_rounds; ++round) {
    int used = 0;
    double mean = 0.0;
    const FitTarget target = MatchPointCloud(points, surface, triangles, cloud_options,
                                             options_.num_threads, &used, &mean);
    if (used < 3) {
      *error = "fewer than 3 scan points lie within --max_distance of the model's surface: is "
               "the scan in the model's frame and units?";
      ok = false;
      break;
    }
    round_distances.push_back(mean);
    if (previous_mean >= 0 &&
        std::abs(previous_mean - mean) <= cloud_options.relative_tolerance * previous_mean) {
      rounds_converged = true;
      break;
    }
    previous_mean = mean;
    if (!FitFrom(target, z, result, error)) {
      ok = false;
      break;
    }
    total_iterations += result->iterations;
    totals.solves += result->solves;
    totals.solve_factorizations += result->solve_factorizations;
    totals.solve_seconds += result->solve_seconds;
    totals.jacobians += result->jacobians;
    totals.jacobian_seconds += result->jacobian_seconds;
    z = result->latent;
    surface = result->surface;
  }
  // Rounds that ran out: whether the last round's solve settled the mean distance (a
  // match of its surface, as the next round's would be).
  if (ok && !rounds_converged && previous_mean >= 0) {
    int used = 0;
    double mean = 0.0;
    MatchPointCloud(points, surface, triangles, cloud_options, options_.num_threads, &used,
                    &mean);
    if (used >= 3) {
      round_distances.push_back(mean);
      rounds_converged =
          std::abs(previous_mean - mean) <= cloud_options.relative_tolerance * previous_mean;
    }
  }
  options_ = saved;
  cloud_options_ = nullptr;
  if (!ok) return false;
  result->iterations = total_iterations;
  result->converged = rounds_converged;
  result->message = rounds_converged
                        ? "the matching rounds converged (the mean distance settled)"
                        : "the matching rounds ended before the mean distance settled (" +
                              result->message + ")";
  result->round_distances = round_distances;
  result->solves = totals.solves;
  result->solve_factorizations = totals.solve_factorizations;
  result->solve_seconds = totals.solve_seconds;
  result->jacobians = totals.jacobians;
  result->jacobian_seconds = totals.jacobian_seconds;
  }
  // Final distances from the scan to the fitted surface (closest points).
  const TriangleBvh bvh(result->surface, triangles);
  const std::vector<ClosestPointResult> closest = bvh.ClosestPoints(points, options_.num_threads);
  double sum = 0, sum_squares = 0, worst = 0;
  int used = 0;
  for (const ClosestPointResult& c : closest) {
    if (cloud_options.max_distance > 0 && c.distance > cloud_options.max_distance) continue;
    ++used;
    sum += c.distance;
    sum_squares += c.distance * c.distance;
    worst = std::max(worst, c.distance);
  }
  result->used_points = used;
  result->matched_fraction = static_cast<double>(used) / static_cast<double>(points.cols());
  result->landmark_mean_error = 0.0;
  if (landmarks.num_points() > 0) {
    const Eigen::Matrix3Xd on_surface = TargetPointsOn(landmarks, result->surface);
    result->landmark_mean_error = (on_surface - landmarks.positions).colwise().norm().mean();
  }
  result->mean_error = used > 0 ? sum / used : 0.0;
  result->rms_error = used > 0 ? std::sqrt(sum_squares / used) : 0.0;
  result->max_error = worst;
  // Landmarks hold the fit only where they weigh in it.
  if (used < 3 && !(landmarks.num_points() > 0 && cloud_options.landmark_weight > 0)) {
    // Points beyond max_distance weigh a constant: with (almost) none near, nothing held
    // the fit (it ends where it started, "converged", with no error to report).
    std::ostringstream out;
    out << "fewer than 3 of the scan's " << points.cols() << " points (" << used
        << ") lie within --max_distance (" << cloud_options.max_distance
        << ") of the fitted surface: is the scan in the model's frame and units, or "
           "--max_distance too small?";
    *error = out.str();
    return false;
  }
  return true;
}

}  // namespace aqs
