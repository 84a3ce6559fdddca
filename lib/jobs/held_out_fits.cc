#include "jobs/held_out_fits.h"

#include <algorithm>

#include "dist/communicator.h"
#include "fit/chosen_start_fit.h"
#include "jobs/held_out_fit_store.h"
#include "util/wall_timer.h"

namespace aqs {

// The start of the auto-encoder's latent fit to `truth` (3 x N, every surface vertex)
// with the fit options `fit` (the physics fits'): its mean training latent or, with
// training_pose_starts, whichever of that and its trained latents (in the order of
// model.poses) has the smallest FitLatent objective (1/N) sum_v |surface_v(z) - y_v|^2 +
// FitPriorTerm(z, N, fit). *name: "mean latent" or the pose's name.
Eigen::VectorXd AutoencoderStart(const SurfaceAutoencoder& autoencoder, const ActiveModel& model,
                                 const Eigen::Matrix3Xd& truth, const LatentFitOptions& fit,
                                 bool training_pose_starts, std::string* name) {
  const int n = static_cast<int>(truth.cols());
  auto objective = [&](const Eigen::VectorXd& z) {
    return (autoencoder.Decode(z) - truth).squaredNorm() / n + autoencoder.FitPriorTerm(z, n, fit);
  };
  Eigen::VectorXd best = autoencoder.MeanLatent();
  *name = kMeanLatentStart;
  if (!training_pose_starts) return best;
  double best_value = objective(best);
  const Eigen::MatrixXd& latents = autoencoder.training_latents();
  for (int p = 0; p < static_cast<int>(latents.cols()) && p < model.num_poses(); ++p) {
    const double value = objective(latents.col(p));
    if (value < best_value) {
      best_value = value;
      best = latents.col(p);
      *name = model.poses[p].name;
    }
  }
  return best;
}

namespace {

// Held-out pose t fitted from rest with a fitter of its own (so its result does not
// depend on the other poses nor on the rank).
void FitOne(const ActiveModel& model, const LatentFitOptions& options, bool training_pose_starts,
            const std::string& name, const Eigen::Matrix3Xd& surface, LatentFitResult* fit,
            double* seconds) {
  WallTimer timer;
  LatentFitter fitter(model, options);
  fitter.set_bone_transforms(RestBoneTransforms(model));
  fitter.set_start_state(model.mesh.vertices);  // from rest: order-independent
  const FitTarget target = FullSurfaceTarget(surface);
  FitStartOptions start_options;
  start_options.training_poses = training_pose_starts;
  std::string failure;
  if (!FitFromChosenStart(&fitter, &target, nullptr, PointCloudFitOptions(), start_options,
                          fitter.MeanLatent(), fit, &failure)) {
    // Left out of the evaluation (n/a), not the end of it: the other fits stand.
    *fit = LatentFitResult();
    fit->failed = true;
    fit->start = kFailedFitStart;
    fit->message = "held-out pose '" + name + "': " + failure;
  }
  if (fit->start == "given") fit->start = kMeanLatentStart;
  *seconds = timer.Seconds();
}

}  // namespace

void FitHeldOutPoses(const ActiveModel& model, const LatentFitOptions& options,
                     bool training_pose_starts, const std::vector<std::string>& names,
                     const std::vector<Eigen::Matrix3Xd>& surfaces,
                     const std::string& store_directory, const Communicator* communicator,
                     HeldOutFits* out) {
  const int count = static_cast<int>(names.size());
  const int rank = communicator == nullptr ? 0 : communicator->rank();
  const int size = communicator == nullptr ? 1 : communicator->size();
  std::vector<LatentFitResult>& fits = out->fits;
  std::vector<double>& seconds = out->seconds;
  fits.assign(count, LatentFitResult());
  seconds.assign(count, 0.0);
  out->kept = 0;
  out->store_warning.clear();
  // Rank 0 takes the fits a stopped run kept, and keeps the new ones as they come.
  HeldOutFitStore store;
  bool keeping = false;
  std::vector<int> done(count, 0);
  if (rank == 0 && !store_directory.empty() && count > 0) {
    std::string error;
    keeping = store.Open(store_directory,
                         HeldOutFitKey(model, options, training_pose_starts), &error);
    if (!keeping) out->store_warning = error;
    for (int t = 0; keeping && t < count; ++t) {
      if (store.Load(model, names[t], surfaces[t], &fits[t], &seconds[t])) {
        done[t] = 1;
        ++out->kept;
      }
    }
  }
  auto keep = [&](int t) {
    std::string error;
    if (keeping &&
        !store.Save(model, names[t], surfaces[t], fits[t], seconds[t], &error)) {
      keeping = false;  // one warning; the fits themselves stand
      out->store_warning = error + " (a stopped run would fit the held-out poses again)";
    }
  };
  if (size > 1 && count > 0) communicator->Broadcast(done.data(), count, 0);
  // In rounds: in round k every rank fits the k-th of its poses still to fit; rank 0
  // gathers the round's fits and keeps them at once (so that a stop loses at most a
  // round's), and no gather exceeds ranks x one fit.
  std::vector<std::vector<int>> pending(size);
  size_t rounds = 0;
  for (int r = 0; r < size; ++r) {
    for (int t : OwnedIndices(count, r, size)) {
      if (!done[t]) pending[r].push_back(t);
    }
    rounds = std::max(rounds, pending[r].size());
  }
  const int block = HeldOutFitBlockSize(model);
  std::vector<int> counts(size, 0);
  std::vector<double> send, received(rank == 0 ? static_cast<size_t>(block) * size : 0);
  for (size_t k = 0; k < rounds; ++k) {
    const bool fits_one = k < pending[rank].size();
    if (fits_one) {
      const int t = pending[rank][k];
      FitOne(model, options, training_pose_starts, names[t], surfaces[t], &fits[t], &seconds[t]);
      if (rank == 0) keep(t);
    }
    if (size == 1) continue;
    // Why each failed fit of the round failed, from the rank that fitted it, for rank
    // 0's log.
    for (int r = 0; r < size; ++r) {
      if (k >= pending[r].size()) continue;
      const int t = pending[r][k];
      int failed = rank == r && fits[t].failed ? 1 : 0;
      communicator->Broadcast(&failed, 1, r);
      if (!failed) continue;
      std::string message = fits[t].message;
      communicator->BroadcastText(&message, r);
      fits[t].message = message;
    }
    send.clear();
    if (fits_one) PackHeldOutFit(model, fits[pending[rank][k]], seconds[pending[rank][k]], &send);
    send.resize(block);  // a valid buffer where this rank sends nothing
    for (int r = 0; r < size; ++r) counts[r] = k < pending[r].size() ? block : 0;
    communicator->GatherToRoot(send.data(), counts, received.data());
    if (rank != 0) continue;
    const double* x = received.data();
    for (int r = 0; r < size; ++r) {
      if (k >= pending[r].size()) continue;
      const int t = pending[r][k];
      if (r != 0) {
        UnpackHeldOutFit(model, x, &fits[t], &seconds[t]);
        keep(t);
      }
      x += block;
    }
  }
}

}  // namespace aqs
