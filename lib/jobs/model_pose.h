#ifndef AQS_JOBS_MODEL_POSE_H_
#define AQS_JOBS_MODEL_POSE_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/rigid_transform.h"
#include "io/latent_io.h"
#include "model/active_model.h"

namespace aqs {

// What a job simulates with a trained model: a latent (latent_dim) and one rigid
// motion per model bone, read from a latent file (aqs_fit --latent_output) or taken
// from a training pose by name.
struct ModelPose {
  Eigen::VectorXd latent;
  std::vector<RigidTransform> bones;
  int training_pose = -1;  // the pose's index when given by name, else -1
  // Set where the latent file was fitted with another learned state of this model
  // (training went on, or started anew, since): what the job should say before it uses it.
  std::string warning;
};

// The model line a latent file of `model` records (io/latent_io.h).
LatentFileModel LatentFileModelOf(const ActiveModel& model);

// Checks a latent file's model line (`origin`, read from `path`) against `model`: none
// (an older file) or this model's are fine; another model's is refused (false, *error
// naming the file); another learned state of this model sets *warning (a latent of an
// earlier training: it may pose the model otherwise than it was fitted to).
bool CheckLatentFileModel(const ActiveModel& model, const std::string& path,
                          const LatentFileModel& origin, std::string* warning,
                          std::string* error);

// Exactly one of latent_file and pose_name must be non-empty (the caller checks).
// Returns false with *error naming the file and line, or the unknown pose and the
// model's poses, or a latent file of another model (CheckLatentFileModel), or a latent
// whose actuations are absurd (CheckLatentActuations), or bones moved absurdly far
// (CheckBoneMotions).
bool ResolveModelPose(const ActiveModel& model, const std::string& latent_file,
                      const std::string& pose_name, ModelPose* pose, std::string* error);

// Checks that latent z of a trained model decodes to actuations a simulation can use:
// entries of at most kMaxActuationStretch (io/actuation_io.h) in magnitude. Returns false
// with *error naming `source` (the latent file) and the largest entry: a latent far
// outside the training latents, whose solve would chase absurd targets.
bool CheckLatentActuations(const ActiveModel& model, const Eigen::VectorXd& z,
                           const std::string& source, std::string* error);

// Checks that no bone motion (one per model bone) moves the centre of the neutral's
// bounding box by more than the model's size (its diagonal): a bone that far away is a
// unit or frame mistake, and its solve inverts the elements it drags. Returns false with
// *error naming `source` (the latent file), the bone and the distance.
bool CheckBoneMotions(const ActiveModel& model, const std::vector<RigidTransform>& bones,
                      const std::string& source, std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_MODEL_POSE_H_
