#ifndef AQS_MODEL_ACTIVE_MODEL_H_
#define AQS_MODEL_ACTIVE_MODEL_H_

#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "geometry/embedding.h"
#include "geometry/rigid_transform.h"
#include "learn/decoder.h"
#include "mesh/surface_mesh.h"
#include "mesh/tet_mesh.h"
#include "model/fit_prior.h"
#include "physics/actuation.h"
#include "physics/boundary_conditions.h"

namespace aqs {

// A rigid bone that drives some fixed simulation vertices: in training pose p, vertex
// v of `vertices` sits at pose_transforms[p] applied to its rest position.
struct Bone {
  std::string name;
  std::vector<int> vertices;
  std::vector<RigidTransform> pose_transforms;  // one per training pose
};

// One example pose of the surface, with what preparation derived from it.
struct TrainingPose {
  std::string name;
  Eigen::Matrix3Xd surface;  // 3 x num_surface_vertices, the neutral's vertex order
  // Volumetric target (6 x num_elements) from embedded simulation; empty if not made.
  ActuationMatrix target;
  // How close the embedded surface of the target simulation came to `surface`.
  double embedding_mean_error = 0.0;
  double embedding_max_error = 0.0;
};

// How far end-to-end training has brought the learned state (the model's
// learned/checkpoint.txt): L-BFGS iterations done in all, and the training loss after
// the last of them (NaN if none), as logged in train/log.csv.
struct TrainingCheckpoint {
  int iterations = 0;
  double loss = std::numeric_limits<double>::quiet_NaN();
  // The iteration whose periodic latent refit (TrainOptions::latent_refit_every) the
  // saved latents include; -1: none recorded. A refit runs after its iteration's
  // checkpoint, so a resumed run refits at `iterations` unless this says it is done.
  int latent_refit_at = -1;
  // The loss's weights the saved iterations were trained with (TrainOptions'
  // regularizers, as text: "latent L energy E decoder D"); empty: not recorded. A run
  // resumed with others says so (the loss column of train/log.csv changes meaning).
  std::string loss_weights;
};

// An active model: the simulation mesh with its material and boundary conditions, the
// surface embedded in it, the training poses, and (once trained) the decoder with one
// latent vector per pose. The on-disk layout is in docs/model_format.md.
struct ActiveModel {
  TetMesh mesh;                      // simulation mesh at rest
  Eigen::VectorXd mu;                // stiffness per element
  std::vector<int> static_vertices;  // fixed at rest
  std::vector<Bone> bones;           // fixed vertices moved rigidly per pose
  SurfaceMesh neutral;               // the neutral surface (polygons kept)
  Embedding embedding;               // each neutral vertex in an element of `mesh`
  std::vector<TrainingPose> poses;
  // What the volumetric targets were made with (model.txt's `targets` line): the
  // fingerprint of VolumetricTargetKey (prepare/target_store.h: the model as prepared and
  // the target options), set by aqs_prepare when every pose's embedded simulation
  // converged; empty otherwise and in models written before it was recorded. A rerun of
  // the pipeline keeps a model whose targets were made from the same (RunPrepareJob,
  // PrepareJobOptions::keep_same_model).
  std::string target_key;

  // The learned part (absent before pre-training: decoder == nullptr).
  std::shared_ptr<const ActuationDecoder> decoder;
  Eigen::VectorXd decoder_params;
  Eigen::MatrixXd latents;            // latent_dim x num_poses
  std::vector<Eigen::Matrix3Xd> states;  // per pose: last equilibrium (empty if none)
  TrainingCheckpoint checkpoint;         // training progress of this learned state
  // The priors of fits (prior.txt; learned from latents and bones when the model has no
  // such file; empty before pre-training).
  FitPrior fit_prior;

  int num_poses() const { return static_cast<int>(poses.size()); }
  int num_surface_vertices() const { return neutral.num_vertices(); }
  int latent_dim() const { return decoder ? decoder->latent_dim() : 0; }
  int PoseIndex(const std::string& name) const;  // -1 if absent
};

// The fixed vertices of the model in a fixed order (static vertices, then each
// bone's), with their positions when bone b has moved by bone_transforms[b].
BoundaryConditions ModelBoundaryConditions(const ActiveModel& model,
                                           const std::vector<RigidTransform>& bone_transforms);
// The same for training pose p (its recorded bone transforms).
BoundaryConditions PoseBoundaryConditions(const ActiveModel& model, int pose);
// Identity transforms for every bone (the rest configuration).
std::vector<RigidTransform> RestBoneTransforms(const ActiveModel& model);

// Checks sizes and indices for consistency (mesh and mu, vertex indices, embedding,
// poses, bone transforms, decoder vs mesh, latents, states). Returns false with
// *error naming `source` and what is inconsistent.
bool ValidateModel(const ActiveModel& model, const std::string& source, std::string* error);

}  // namespace aqs

#endif  // AQS_MODEL_ACTIVE_MODEL_H_
