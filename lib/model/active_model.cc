#include "model/active_model.h"

#include <sstream>

#include <glog/logging.h>

namespace aqs {

int ActiveModel::PoseIndex(const std::string& name) const {
  for (int p = 0; p < num_poses(); ++p) {
    if (poses[p].name == name) return p;
  }
  return -1;
}

std::vector<RigidTransform> RestBoneTransforms(const ActiveModel& model) {
  return std::vector<RigidTransform>(model.bones.size());
}

BoundaryConditions ModelBoundaryConditions(const ActiveModel& model,
                                           const std::vector<RigidTransform>& bone_transforms) {
  CHECK_EQ(bone_transforms.size(), model.bones.size());
  BoundaryConditions bc;
  bc.vertices = model.static_vertices;
  for (const Bone& bone : model.bones) {
    bc.vertices.insert(bc.vertices.end(), bone.vertices.begin(), bone.vertices.end());
  }
  bc.positions.resize(3, bc.vertices.size());
  size_t i = 0;
  for (int v : model.static_vertices) bc.positions.col(i++) = model.mesh.vertices.col(v);
  for (size_t b = 0; b < model.bones.size(); ++b) {
    for (int v : model.bones[b].vertices) {
      bc.positions.col(i++) = bone_transforms[b].ApplyToPoint(model.mesh.vertices.col(v));
    }
  }
  return bc;
}

BoundaryConditions PoseBoundaryConditions(const ActiveModel& model, int pose) {
  CHECK(pose >= 0 && pose < model.num_poses());
  std::vector<RigidTransform> transforms;
  for (const Bone& bone : model.bones) transforms.push_back(bone.pose_transforms[pose]);
  return ModelBoundaryConditions(model, transforms);
}

bool ValidateModel(const ActiveModel& model, const std::string& source, std::string* error) {
  std::ostringstream out;
  out << source << ": ";
  const int nv = model.mesh.num_vertices();
  const int ne = model.mesh.num_tets();
  const int ns = model.neutral.num_vertices();
  auto fail = [&](const std::string& what) {
    *error = out.str() + what;
    return false;
  };
  if (ne == 0) return fail("the simulation mesh has no elements");
  if (model.mu.size() != ne) return fail("mu has " + std::to_string(model.mu.size()) +
                                         " values for " + std::to_string(ne) + " elements");
  for (int e = 0; e < ne; ++e) {
    if (!(model.mu[e] > 0)) return fail("mu of element " + std::to_string(e) + " is not positive");
  }
  std::vector<bool> fixed(nv, false);
  auto claim = [&](int v, const std::string& who) {
    if (v < 0 || v >= nv) {
      *error = out.str() + who + " lists vertex " + std::to_string(v) + ", outside [0, " +
               std::to_string(nv) + ")";
      return false;
    }
    if (fixed[v]) {
      *error = out.str() + "vertex " + std::to_string(v) + " is fixed twice (" + who + ")";
      return false;
    }
    fixed[v] = true;
    return true;
  };
  for (int v : model.static_vertices) {
    if (!claim(v, "the static fixed set")) return false;
  }
  for (const Bone& bone : model.bones) {
    for (int v : bone.vertices) {
      if (!claim(v, "bone '" + bone.name + "'")) return false;
    }
    if (static_cast<int>(bone.pose_transforms.size()) != model.num_poses()) {
      return fail("bone '" + bone.name + "' has " + std::to_string(bone.pose_transforms.size()) +
                  " pose transforms for " + std::to_string(model.num_poses()) + " poses");
    }
  }
  if (model.embedding.num_points() != ns) {
    return fail("the embedding has " + std::to_string(model.embedding.num_points()) +
                " points for a surface of " + std::to_string(ns) + " vertices");
  }
  if (model.embedding.weights.cols() != ns || model.embedding.offsets.cols() != ns) {
    return fail("the embedding's weights or offsets do not match the surface");
  }
  for (int i = 0; i < ns; ++i) {
    if (model.embedding.element[i] < 0 || model.embedding.element[i] >= ne) {
      return fail("surface vertex " + std::to_string(i) + " is embedded in element " +
                  std::to_string(model.embedding.element[i]) + ", outside the mesh");
    }
  }
  for (const TrainingPose& pose : model.poses) {
    if (pose.surface.cols() != ns) {
      return fail("pose '" + pose.name + "' has " + std::to_string(pose.surface.cols()) +
                  " vertices, the neutral surface " + std::to_string(ns));
    }
    if (pose.target.cols() != 0 && pose.target.cols() != ne) {
      return fail("the volumetric target of pose '" + pose.name + "' has " +
                  std::to_string(pose.target.cols()) + " elements, the mesh " + std::to_string(ne));
    }
  }
  if (model.decoder) {
    if (model.decoder->num_elements() != ne) {
      return fail("the decoder drives " + std::to_string(model.decoder->num_elements()) +
                  " elements, the mesh has " + std::to_string(ne));
    }
    if (model.decoder_params.size() != model.decoder->num_parameters()) {
      return fail("the decoder needs " + std::to_string(model.decoder->num_parameters()) +
                  " parameters, " + std::to_string(model.decoder_params.size()) + " given");
    }
    if (model.latents.rows() != model.decoder->latent_dim() ||
        model.latents.cols() != model.num_poses()) {
      return fail("latents are " + std::to_string(model.latents.rows()) + " x " +
                  std::to_string(model.latents.cols()) + ", expected latent_dim x poses = " +
                  std::to_string(model.decoder->latent_dim()) + " x " +
                  std::to_string(model.num_poses()));
    }
  }
  if (!model.states.empty()) {
    if (static_cast<int>(model.states.size()) != model.num_poses()) {
      return fail("states for " + std::to_string(model.states.size()) + " of " +
                  std::to_string(model.num_poses()) + " poses");
    }
    for (int p = 0; p < model.num_poses(); ++p) {
      if (model.states[p].cols() != 0 && model.states[p].cols() != nv) {
        return fail("the state of pose '" + model.poses[p].name + "' has the wrong vertex count");
      }
    }
  }
  return true;
}

}  // namespace aqs
