#include "dist/model_sharing.h"

#include <algorithm>
#include <cstdint>
#include <vector>

#include <glog/logging.h>

#include "model/model_fingerprint.h"

namespace aqs {
namespace {

void Split(uint64_t value, int* words) {
  words[0] = static_cast<int>(static_cast<uint32_t>(value >> 32));
  words[1] = static_cast<int>(static_cast<uint32_t>(value));
}

// Rank 0's Gaussian (mean of `size` numbers and its covariance) on every rank.
void ShareGaussian(const Communicator& comm, int size, GaussianPrior* prior) {
  Eigen::VectorXd mean = comm.is_root() ? prior->mean : Eigen::VectorXd(size);
  Eigen::MatrixXd covariance = comm.is_root() ? prior->covariance : Eigen::MatrixXd(size, size);
  CHECK_EQ(mean.size(), size);
  CHECK_EQ(covariance.rows(), size);
  comm.Broadcast(mean.data(), size, 0);
  comm.Broadcast(covariance.data(), size * size, 0);
  if (comm.is_root()) return;
  prior->mean = mean;
  CHECK(prior->SetCovariance(covariance)) << "rank 0's prior covariance is definite";
}

// Rank 0's fit prior on every rank (another machine's copy of prior.txt may be an older
// one, learned from older latents).
void ShareFitPrior(const Communicator& comm, ActiveModel* model) {
  int has = model->fit_prior.empty() ? 0 : 1;
  comm.Broadcast(&has, 1, 0);
  if (!has) {
    model->fit_prior = FitPrior();
    return;
  }
  comm.BroadcastText(&model->fit_prior.center, 0);
  ShareGaussian(comm, model->latent_dim(), &model->fit_prior.latent);
  model->fit_prior.bones.resize(model->bones.size());
  for (GaussianPrior& bone : model->fit_prior.bones) ShareGaussian(comm, 6, &bone);
}

}  // namespace

bool ShareModel(const Communicator& comm, const std::string& directory, bool loaded,
                ActiveModel* model, std::string* error) {
  if (!comm.Agree(loaded, error)) return false;
  if (comm.size() == 1) return true;
  // Identity: rank 0's fingerprint and decoder architecture against each rank's.
  // And the neutral's faces, which ModelFingerprint leaves out but point-cloud fits read.
  int own[6], root[6];
  Split(ModelFingerprint(*model), own);
  Split(DecoderArchitectureFingerprint(*model), own + 2);
  uint64_t faces = 0;
  CHECK(ParseFingerprint(FacesFingerprint(model->neutral), &faces));
  Split(faces, own + 4);
  std::copy(own, own + 6, root);
  comm.Broadcast(root, 6, 0);
  std::string mismatch;
  if (own[0] != root[0] || own[1] != root[1]) {
    mismatch = "the model at " + directory + " is another model than rank 0's (another mesh, "
               "fixed vertices, bones, embedding or pose set): every rank must read the same "
               "model (copy the whole directory to every machine)";
  } else if (own[4] != root[4] || own[5] != root[5]) {
    mismatch = "the model at " + directory + " has a neutral.obj with other faces than rank "
               "0's (triangulated again?): every rank must read the same model (copy the "
               "whole directory to every machine)";
  } else if (own[2] != root[2] || own[3] != root[3]) {
    mismatch = "the model at " + directory + " has another decoder than rank 0's (its copy of "
               "learned/ is from another pre-training): copy the whole directory to every "
               "machine again";
  }
  if (!mismatch.empty()) *error = mismatch;
  if (!comm.Agree(mismatch.empty(), error)) return false;
  if (!model->decoder) return true;  // the same on every rank: nothing learned to share
  // Rank 0's learned numbers.
  comm.Broadcast(model->decoder_params.data(), static_cast<int>(model->decoder_params.size()), 0);
  comm.Broadcast(model->latents.data(), static_cast<int>(model->latents.size()), 0);
  ShareFitPrior(comm, model);
  int iterations[2] = {model->checkpoint.iterations, model->checkpoint.latent_refit_at};
  double loss = model->checkpoint.loss;
  comm.Broadcast(iterations, 2, 0);
  comm.Broadcast(&loss, 1, 0);
  model->checkpoint.iterations = iterations[0];
  model->checkpoint.latent_refit_at = iterations[1];
  model->checkpoint.loss = loss;
  // No stored equilibria on rank 0: none on any rank (as an empty list, not one empty
  // state per pose, so that the learned state's fingerprint is the one rank 0 read).
  int any_states = model->states.empty() ? 0 : 1;
  comm.Broadcast(&any_states, 1, 0);
  if (!any_states) {
    model->states.clear();
    return true;
  }
  const int num_poses = model->num_poses();
  const int nv = model->mesh.num_vertices();
  std::vector<int> have(num_poses, 0);
  if (comm.is_root()) {
    for (int p = 0; p < num_poses && p < static_cast<int>(model->states.size()); ++p) {
      have[p] = model->states[p].cols() == nv ? 1 : 0;
    }
  }
  comm.Broadcast(have.data(), num_poses, 0);
  model->states.resize(num_poses);
  for (int p = 0; p < num_poses; ++p) {
    if (!have[p]) {
      model->states[p].resize(3, 0);
      continue;
    }
    model->states[p].resize(3, nv);
    comm.Broadcast(model->states[p].data(), 3 * nv, 0);
  }
  return true;
}

}  // namespace aqs
