#include "jobs/model_pose.h"

#include <sstream>

#include "geometry/points_near_model.h"
#include "io/actuation_io.h"
#include "io/latent_io.h"
#include "model/model_fingerprint.h"

namespace aqs {

bool ResolveModelPose(const ActiveModel& model, const std::string& latent_file,
                      const std::string& pose_name, ModelPose* pose, std::string* error) {
  *pose = ModelPose();
  if (!latent_file.empty()) {
    std::vector<std::string> names;
    for (const Bone& bone : model.bones) names.push_back(bone.name);
    LatentFileModel origin;
    return ReadLatentFile(latent_file, model.latent_dim(), names, &pose->latent, &pose->bones,
                          &origin, error) &&
           CheckLatentFileModel(model, latent_file, origin, &pose->warning, error) &&
           CheckLatentActuations(model, pose->latent, latent_file, error) &&
           CheckBoneMotions(model, pose->bones, latent_file, error);
  }
  const int p = model.PoseIndex(pose_name);
  if (p < 0) {
    std::string known;
    for (const TrainingPose& training : model.poses) known += " " + training.name;
    *error = "the model has no training pose '" + pose_name + "'; it has:" + known;
    return false;
  }
  pose->training_pose = p;
  pose->latent = model.latents.col(p);
  for (const Bone& bone : model.bones) pose->bones.push_back(bone.pose_transforms[p]);
  return true;
}

LatentFileModel LatentFileModelOf(const ActiveModel& model) {
  return {FingerprintText(ModelFingerprint(model)),
          FingerprintText(LearnedStateFingerprint(model))};
}

bool CheckLatentFileModel(const ActiveModel& model, const std::string& path,
                          const LatentFileModel& origin, std::string* warning,
                          std::string* error) {
  if (origin.model.empty()) return true;
  const LatentFileModel own = LatentFileModelOf(model);
  if (origin.model != own.model) {
    *error = path + ": a latent of another model (its model line names model " + origin.model +
             "; this model is " + own.model + "): fit it again with this model";
    return false;
  }
  if (origin.learned != own.learned) {
    *warning = path + ": fitted with another learned state of this model (" + origin.learned +
               "; now " + own.learned + ": trained further or anew since); it may pose the " +
               "model otherwise than it was fitted to";
  }
  return true;
}

bool CheckLatentActuations(const ActiveModel& model, const Eigen::VectorXd& z,
                           const std::string& source, std::string* error) {
  if (!model.decoder) return true;
  ActuationMatrix a;
  DecoderWorkspace workspace;
  model.decoder->Decode(model.decoder_params.data(), z, &a, &workspace);
  const double largest = a.cwiseAbs().maxCoeff();
  if (largest <= kMaxActuationStretch) return true;
  std::ostringstream out;
  out << source << ": the latent decodes to actuations with entries up to " << largest
      << " (more than " << kMaxActuationStretch
      << "): it is far outside the model's training latents";
  *error = out.str();
  return false;
}

bool CheckBoneMotions(const ActiveModel& model, const std::vector<RigidTransform>& bones,
                      const std::string& source, std::string* error) {
  const Eigen::Matrix3Xd& neutral = model.neutral.vertices;
  if (neutral.cols() == 0) return true;
  const double size = ModelSize(neutral);
  for (size_t b = 0; b < bones.size() && b < model.bones.size(); ++b) {
    const double moved = CentreDisplacement(neutral, bones[b]);
    if (!(moved <= size)) {
      std::ostringstream out;
      out << source << ": bone '" << model.bones[b].name << "' moves the model's centre by "
          << moved << ", more than the model's size (" << size << "): another unit or frame?";
      *error = out.str();
      return false;
    }
  }
  return true;
}

}  // namespace aqs
