#include "model/model_fingerprint.h"

#include <cstdio>
#include <vector>

#include "util/fnv_hash.h"

namespace aqs {

uint64_t ModelFingerprint(const ActiveModel& model) {
  FnvHasher h;
  h.AddMatrix(model.mesh.vertices);
  h.AddMatrix(model.mesh.tets);
  h.AddMatrix(model.mu);
  h.Add(model.static_vertices.data(), model.static_vertices.size());
  for (const Bone& bone : model.bones) {
    h.Add(bone.name);
    h.Add(bone.vertices.data(), bone.vertices.size());
    for (const RigidTransform& t : bone.pose_transforms) {
      h.AddMatrix(t.rotation);
      h.AddMatrix(t.translation);
    }
  }
  h.AddMatrix(model.neutral.vertices);
  h.Add(model.embedding.element.data(), model.embedding.element.size());
  h.AddMatrix(model.embedding.weights);
  h.AddMatrix(model.embedding.offsets);
  for (const TrainingPose& pose : model.poses) {
    h.Add(pose.name);
    h.AddMatrix(pose.surface);
  }
  return h.hash();
}

uint64_t DecoderArchitectureFingerprint(const ActiveModel& model) {
  if (!model.decoder) return 0;
  const ActuationDecoder& d = *model.decoder;
  std::vector<double> numbers = {static_cast<double>(d.latent_dim()),
                                 static_cast<double>(d.spec().activation),
                                 d.spec().output_scale,
                                 d.spec().anchored ? 1.0 : 0.0,
                                 d.spec().linear_skip ? 1.0 : 0.0,
                                 static_cast<double>(d.num_nodes()),
                                 static_cast<double>(d.num_elements()),
                                 static_cast<double>(d.num_parameters())};
  for (int width : d.spec().hidden_dims) numbers.push_back(width);
  // Where the control nodes sit (a spacing changed within what keeps the node set
  // changes every decoded actuation, and left the fingerprint as it was).
  const GridFieldDescription& field = d.field().description();
  numbers.push_back(field.per_element ? 1.0 : 0.0);
  for (int a = 0; a < 3; ++a) numbers.push_back(field.origin[a]);
  numbers.push_back(field.spacing);
  for (int a = 0; a < 3; ++a) numbers.push_back(field.grid_dims[a]);
  uint64_t hash = Fnv1a(numbers.data(), sizeof(double) * numbers.size(), kFnvOffsetBasis);
  hash = Fnv1a(field.nodes.data(), sizeof(int) * field.nodes.size(), hash);
  return hash | 1;
}

uint64_t LearnedStateFingerprint(const ActiveModel& model) {
  FnvHasher h;
  const uint64_t architecture = DecoderArchitectureFingerprint(model);
  h.Add(&architecture, 1);
  h.AddMatrix(model.decoder_params);
  h.AddMatrix(model.latents);
  for (const Eigen::Matrix3Xd& state : model.states) h.AddMatrix(state);
  const FitPrior& prior = model.fit_prior;
  h.Add(prior.center);
  h.AddMatrix(prior.latent.mean);
  h.AddMatrix(prior.latent.covariance);
  for (const GaussianPrior& g : prior.bones) {
    h.AddMatrix(g.mean);
    h.AddMatrix(g.covariance);
  }
  return h.hash();
}

std::string FacesFingerprint(const SurfaceMesh& surface) {
  uint64_t hash = kFnvOffsetBasis;
  hash = Fnv1a(surface.triangles.data(), sizeof(int) * surface.triangles.size(), hash);
  hash = Fnv1a(surface.face_offsets.data(), sizeof(int) * surface.face_offsets.size(), hash);
  hash = Fnv1a(surface.face_vertices.data(), sizeof(int) * surface.face_vertices.size(), hash);
  return FingerprintText(hash);
}

std::string FingerprintText(uint64_t fingerprint) {
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(fingerprint));
  return text;
}

bool ParseFingerprint(const std::string& text, uint64_t* fingerprint) {
  if (text.empty() || text.size() > 16) return false;
  uint64_t value = 0;
  for (char c : text) {
    int digit = 0;
    if (c >= '0' && c <= '9') {
      digit = c - '0';
    } else if (c >= 'a' && c <= 'f') {
      digit = c - 'a' + 10;
    } else if (c >= 'A' && c <= 'F') {
      digit = c - 'A' + 10;
    } else {
      return false;
    }
    value = value * 16 + digit;
  }
  *fingerprint = value;
  return true;
}

}  // namespace aqs
