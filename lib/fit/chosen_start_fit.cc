#include "fit/chosen_start_fit.h"

#include <algorithm>

#include <glog/logging.h>

namespace aqs {
namespace {

// Bone motions within this many standard deviations of the prior's centre are never
// beyond the training poses' (a bone that no training pose moves has the prior's floor
// spread, and fits move it a little to trade against the latent prior).
constexpr double kWithinDeviations = 1.0;

bool SameBones(const std::vector<RigidTransform>& a, const std::vector<RigidTransform>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i) {
    if (a[i].rotation != b[i].rotation || a[i].translation != b[i].translation) return false;
  }
  return true;
}

// One fit from the fitter's current bones and start state.
bool FitOnce(LatentFitter* fitter, const FitTarget* target, const Eigen::Matrix3Xd* points,
             const PointCloudFitOptions& cloud_options, const Eigen::VectorXd& z,
             LatentFitResult* result, std::string* error) {
  return points != nullptr ? fitter->FitPointCloud(*points, cloud_options, z, result, error)
                           : fitter->Fit(*target, z, result, error);
}

}  // namespace

bool BonesBeyondTrainingPoses(const FitPrior& prior, const std::vector<Bone>& model_bones,
                              const std::vector<RigidTransform>& bones) {
  CHECK_EQ(bones.size(), model_bones.size());
  for (size_t b = 0; b < bones.size() && b < prior.bones.size(); ++b) {
    if (prior.bones[b].size() != 6 || model_bones[b].pose_transforms.empty()) continue;
    Eigen::VectorXd parameters(6);
    double widest = kWithinDeviations * kWithinDeviations;
    for (const RigidTransform& pose : model_bones[b].pose_transforms) {
      BoneTransformToParameters(pose, parameters.data());
      widest = std::max(widest, prior.bones[b].SquaredMahalanobis(parameters));
    }
    BoneTransformToParameters(bones[b], parameters.data());
    if (prior.bones[b].SquaredMahalanobis(parameters) > widest) return true;
  }
  return false;
}

bool FitFromChosenStart(LatentFitter* fitter, const FitTarget* target,
                        const Eigen::Matrix3Xd* points, const PointCloudFitOptions& cloud_options,
                        const FitStartOptions& options, const Eigen::VectorXd& given,
                        LatentFitResult* result, std::string* error) {
  CHECK((target != nullptr) != (points != nullptr));
  result->start.clear();  // set once a start is chosen
  const std::vector<RigidTransform> given_bones = fitter->bone_transforms();
  const Eigen::Matrix3Xd given_state = fitter->start_state();
  Eigen::VectorXd z = given;
  std::string start;
  if (!fitter->ChooseStart(target, points, cloud_options, options, &z, &start, error)) {
    return false;
  }
  const bool from_given = start == "given" || (z == given && SameBones(fitter->bone_transforms(),
                                                                        given_bones));
  std::string first_error;
  const bool first_ok = FitOnce(fitter, target, points, cloud_options, z, result, &first_error);
  AddFitCounters(fitter->start_choice_work(), result);
  result->start = start;
  result->retry_reason.clear();
  result->retry_kept = false;
  if (!options.retry_from_given || from_given) {
    if (!first_ok) *error = first_error;
    return first_ok;
  }
  if (!first_ok || result->failed) {
    result->retry_reason = "the fit from " + start + " failed";
  } else if (!result->converged) {
    result->retry_reason = "the fit from " + start + " did not converge";
  } else if (BonesBeyondTrainingPoses(fitter->prior(), fitter->model().bones, result->bones)) {
    result->retry_reason = "the fit from " + start + " moved a bone beyond the training poses'";
  } else {
    return true;
  }
  const LatentFitResult first = *result;
  fitter->set_bone_transforms(given_bones);
  fitter->set_start_state(given_state);
  fitter->ForgetFactor();
  LatentFitResult second;
  std::string second_error;
  const bool second_ok =
      FitOnce(fitter, target, points, cloud_options, given, &second, &second_error) &&
      !second.failed;
  bool keep_second = second_ok && !(first_ok && !first.failed);
  if (second_ok && !keep_second) {
    fitter->set_bone_transforms(first.bones);
    const double first_objective =
        fitter->StartObjective(target, points, cloud_options, first.surface, first.latent);
    fitter->set_bone_transforms(second.bones);
    const double second_objective =
        fitter->StartObjective(target, points, cloud_options, second.surface, second.latent);
    keep_second = second_objective < first_objective;
  }
  *result = keep_second ? second : first;
  AddFitCounters(keep_second ? first : second, result);
  result->start = keep_second ? "given" : start;
  result->retry_reason = first.retry_reason;
  result->retry_kept = keep_second;
  fitter->set_bone_transforms(result->bones);
  fitter->set_start_state(result->state);
  if (!first_ok && !keep_second) {
    *error = first_error;
    return false;
  }
  return true;
}

}  // namespace aqs
