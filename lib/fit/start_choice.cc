// Where fits start: the objective of a fit at a simulated surface, and
// LatentFitter::ChooseStart among the given start and the training poses.

#include <algorithm>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <glog/logging.h>

#include "fit/bone_parameters.h"
#include "fit/fit_target.h"
#include "fit/latent_fit.h"
#include "fit/point_cloud_matching.h"
#include "geometry/embedding.h"

namespace aqs {

double LatentFitter::Objective(const FitTarget& target, const Eigen::Matrix3Xd& surface,
                               const Eigen::VectorXd& z) const {
  return ObjectiveWithPriors(target, surface, z, options_.latent_prior, options_.bone_prior);
}

double LatentFitter::ObjectiveWithPriors(const FitTarget& target, const Eigen::Matrix3Xd& surface,
                                         const Eigen::VectorXd& z, double latent_prior,
                                         double bone_prior) const {
  return TargetDataTerm(target, surface) +
         PriorTerms(z, latent_prior, bone_prior, PriorPoints(target, options_.prior_points_cap));
}

double LatentFitter::PriorTerms(const Eigen::VectorXd& z, double latent_prior, double bone_prior,
                                double prior_points) const {
  double cost = options_.latent_regularization * z.squaredNorm();
  if (latent_prior > 0) {
    cost += latent_prior / prior_points * prior_.latent.SquaredMahalanobis(z);
  }
  if (options_.fit_bones && bone_prior > 0) {
    for (size_t b = 0; b < bones_.size(); ++b) {
      Eigen::VectorXd parameters(6);
      BoneTransformToParameters(bones_[b], parameters.data());
      cost += bone_prior / prior_points * prior_.bones[b].SquaredMahalanobis(parameters);
    }
  }
  if (temporal_weight_ > 0) {
    cost += temporal_weight_ / prior_points *
            (prior_.latent.whitening * (z - temporal_latent_)).squaredNorm();
    for (size_t b = 0; options_.fit_bones && b < bones_.size(); ++b) {
      Eigen::Matrix<double, 6, 1> parameters;
      BoneTransformToParameters(bones_[b], parameters.data());
      cost += temporal_weight_ / prior_points *
              (prior_.bones[b].whitening * (parameters - temporal_bones_[b])).squaredNorm();
    }
  }
  return cost;
}

double LatentFitter::StartObjective(const FitTarget* target, const Eigen::Matrix3Xd* points,
                                    const PointCloudFitOptions& cloud_options,
                                    const Eigen::Matrix3Xd& surface,
                                    const Eigen::VectorXd& z) const {
  CHECK((target != nullptr) != (points != nullptr));
  if (target != nullptr) return Objective(*target, surface, z);
  // Without the bone prior: a scan fit's is centred on its start, so every start is at
  // its centre.
  const double latent_prior = ScanLatentPrior(cloud_options);
  double cost = 0.0;
  int used = 0;
  if (cloud_options.rematch_every_evaluation) {
    // What that fit minimizes (FitFrom: the priors over min(M, cap) points).
    cost = CloudDataTerm(*points, surface, model_.neutral.triangles, cloud_options,
                         options_.num_threads, &used);
    const double m = static_cast<double>(points->cols());
    const double cap = options_.prior_points_cap;
    cost += PriorTerms(z, latent_prior, 0.0, cap > 0 ? std::min(m, cap) : m);
  } else {
    // What a matching round minimizes.
    double mean = 0.0;
    const FitTarget matched = MatchPointCloud(*points, surface, model_.neutral.triangles,
                                              cloud_options, options_.num_threads, &used, &mean);
    cost = ObjectiveWithPriors(matched, surface, z, latent_prior, 0.0);
  }
  // Fewer than 3 matched points hold nothing, unless landmarks that weigh in the fit do;
  // matching rounds refuse such a match whatever the landmarks (FitPointCloud), and its
  // data term is 0/0 there. Otherwise the landmarks weigh in both modes, as in the fit.
  const bool landmarks_weigh =
      cloud_options.landmarks.num_points() > 0 && cloud_options.landmark_weight > 0;
  if (used < 3 && !(landmarks_weigh && cloud_options.rematch_every_evaluation)) {
    return std::numeric_limits<double>::infinity();
  }
  if (landmarks_weigh) {
    cost += cloud_options.landmark_weight * TargetDataTerm(cloud_options.landmarks, surface);
  }
  return cost;
}

bool LatentFitter::ChooseStart(const FitTarget* target, const Eigen::Matrix3Xd* points,
                               const PointCloudFitOptions& cloud_options,
                               const FitStartOptions& options, Eigen::VectorXd* z,
                               std::string* name, std::string* error) {
  CHECK((target != nullptr) != (points != nullptr));
  CHECK_EQ(z->size(), model_.latent_dim());
  auto score = [&](const Eigen::Matrix3Xd& surface, const Eigen::VectorXd& latent) {
    return StartObjective(target, points, cloud_options, surface, latent);
  };
  stats_ = LatentFitResult();  // the choice's own work (start_choice_work)
  double best = std::numeric_limits<double>::infinity();
  Eigen::VectorXd best_z = *z;
  std::vector<RigidTransform> best_bones = bones_;
  Eigen::Matrix3Xd best_state;
  std::string best_name;
  const std::vector<RigidTransform> given_bones = bones_;
  auto at_given_bones = [&](int p) {
    for (size_t b = 0; b < given_bones.size(); ++b) {
      if (given_bones[b].rotation != model_.bones[b].pose_transforms[p].rotation ||
          given_bones[b].translation != model_.bones[b].pose_transforms[p].translation) {
        return false;
      }
    }
    return true;
  };
  // The given start is a training pose's (e.g. the prior's centre, the neutral): that
  // candidate covers it, with its stored equilibrium instead of a solve.
  bool given_is_training_pose = false;
  for (int p = 0; options.training_poses && p < model_.num_poses(); ++p) {
    given_is_training_pose |= p < static_cast<int>(model_.states.size()) &&
                              model_.states[p].cols() == model_.mesh.num_vertices() &&
                              *z == Eigen::VectorXd(model_.latents.col(p)) && at_given_bones(p);
  }
  if (!given_is_training_pose) {
    Eigen::Matrix3Xd state, surface;
    std::string simulate_error;
    if (Simulate(*z, &state, &surface, &simulate_error)) {
      // A score that is not a number must not block every candidate's `s < best`.
      best = score(surface, *z);
      if (!(best < std::numeric_limits<double>::infinity())) {
        best = std::numeric_limits<double>::infinity();
      }
      best_state = state;
      best_name = "given";
    } else {
      *error = simulate_error;
    }
  }
  for (int p = 0; options.training_poses && p < model_.num_poses(); ++p) {
    if (p >= static_cast<int>(model_.states.size()) ||
        model_.states[p].cols() != model_.mesh.num_vertices()) {
      continue;
    }
    // Bones that are not fitted stay where they were set: only the training poses at
    // those motions can start the fit (another pose's would hold the bones there).
    if (!options_.fit_bones && !at_given_bones(p)) continue;
    for (size_t b = 0; b < bones_.size(); ++b) bones_[b] = model_.bones[b].pose_transforms[p];
    const Eigen::Matrix3Xd surface =
        EmbeddedPositions(model_.embedding, model_.mesh.tets, model_.states[p]);
    const double s = score(surface, model_.latents.col(p));
    if (s < best) {
      best = s;
      best_z = model_.latents.col(p);
      best_bones = bones_;
      best_state = model_.states[p];
      best_name = model_.poses[p].name;
    }
  }
  bones_ = given_bones;
  start_choice_work_ = stats_;
  if (points != nullptr && !std::isfinite(best)) {
    // Every start that could be simulated matched fewer than 3 of the scan's points.
    best_name.clear();
    std::ostringstream out;
    out << "fewer than 3 of the scan's " << points->cols() << " points lie within "
        << "--max_distance (" << cloud_options.max_distance << ") of the surface of any start "
        << "(the given one and the training poses): is the scan in another unit or frame "
        << "than the model, or --max_distance too small?";
    if (!error->empty()) out << " (the given start: " << *error << ")";
    *error = out.str();
  }
  if (best_name.empty()) {
    *error = "no start: " + (error->empty() ? std::string("no start could be simulated")
                                             : *error);
    return false;
  }
  set_bone_transforms(best_bones);
  set_start_state(best_state);
  *z = best_z;
  *name = best_name;
  return true;
}

}  // namespace aqs
