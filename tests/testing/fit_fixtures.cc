#include "testing/fit_fixtures.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "fit/latent_fit.h"
#include "prepare/volumetric_targets.h"
#include "testing/synthetic_muscles.h"
#include "testing/test_meshes.h"
#include "train/pretrain.h"

namespace aqs {
namespace testing {

ActiveModel PretrainedBarForFits(bool with_bone, bool with_free_piece) {
  SyntheticMuscles data = MakeSyntheticMuscles(8, 0, 0.3, 21);
  ActiveModel model = data.model;
  if (with_free_piece) {
    const int m = model.mesh.num_tets();
    AppendLoneElement(&model.mesh, 0.3, 0.2);
    model.mu.conservativeResize(m + 1);
    model.mu(m) = model.mu(0);
  }
  std::ostringstream log;
  std::string error;
  EXPECT_TRUE(MakeVolumetricTargets(VolumetricTargetOptions(), &model, log, &error)) << error;
  PretrainOptions pretrain;
  pretrain.spec.latent_dim = 3;
  pretrain.spec.hidden_dims = {16, 16};
  // tanh: a smooth decoder, so that finite differences are exact to high order (ELU is
  // not twice differentiable at 0, which spoils Ridders extrapolation near kinks).
  pretrain.spec.activation = Activation::kTanh;
  pretrain.field.node_spacing = 0.25;
  pretrain.max_iterations = 150;
  pretrain.log_every = 0;
  PretrainReport report;
  EXPECT_TRUE(Pretrain(pretrain, &model, &report, log, &error)) << error;
  if (with_bone) {
    Bone base;
    base.name = "base";
    base.vertices = model.static_vertices;
    base.pose_transforms.assign(model.num_poses(), RigidTransform());
    model.static_vertices.clear();
    model.bones.push_back(base);
  }
  return model;
}

bool StoreTrainingEquilibria(ActiveModel* model) {
  LatentFitter simulator(*model, LatentFitOptions());
  std::vector<Eigen::Matrix3Xd> states(model->num_poses());
  for (int p = 0; p < model->num_poses(); ++p) {
    std::vector<RigidTransform> bones;
    for (const Bone& bone : model->bones) bones.push_back(bone.pose_transforms[p]);
    simulator.set_bone_transforms(bones);
    Eigen::Matrix3Xd surface;
    std::string error;
    if (!simulator.Simulate(model->latents.col(p), &states[p], &surface, &error)) return false;
  }
  model->states = states;
  return true;
}

}  // namespace testing
}  // namespace aqs
