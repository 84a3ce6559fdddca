#include "jobs/held_out_fits.h"

#include "dist/communicator.h"
#include "fit/chosen_start_fit.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

// A held-out fit's start as a number, to gather it among ranks: the training pose's
// index, or -1 for the mean training latent; and back.
// A fit's start as a number between ranks: the training pose's index, -1 for the mean
// latent, -2 for a failed fit.
int StartIndex(const ActiveModel& model, const std::string& start) {
  if (start == kFailedFitStart) return -2;
  for (int p = 0; p < model.num_poses(); ++p) {
    if (model.poses[p].name == start) return p;
  }
  return -1;
}
std::string StartName(const ActiveModel& model, int index) {
  if (index == -2) return kFailedFitStart;
  return index >= 0 && index < model.num_poses() ? model.poses[index].name : kMeanLatentStart;
}

}  // namespace

// The start of the auto-encoder's latent fit to `truth` (3 x N, every surface vertex):
// its mean training latent or, with training_pose_starts, whichever of that
// and its trained latents (in the order of model.poses) has the smallest FitLatent
// objective (1/N) sum_v |surface_v(z) - y_v|^2 + lambda |z|^2. *name: "mean latent" or
// the pose's name.
Eigen::VectorXd AutoencoderStart(const SurfaceAutoencoder& autoencoder, const ActiveModel& model,
                                 const Eigen::Matrix3Xd& truth, bool training_pose_starts,
                                 std::string* name) {
  const double lambda = autoencoder.options().latent_regularization;
  auto objective = [&](const Eigen::VectorXd& z) {
    return (autoencoder.Decode(z) - truth).squaredNorm() / truth.cols() + lambda * z.squaredNorm();
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

void FitHeldOutPoses(const ActiveModel& model, const LatentFitOptions& options,
                     bool training_pose_starts, const std::vector<std::string>& names,
                     const std::vector<Eigen::Matrix3Xd>& surfaces,
                     const Communicator* communicator, std::vector<LatentFitResult>* fits,
                     std::vector<double>* seconds) {
  const int count = static_cast<int>(names.size());
  const int rank = communicator == nullptr ? 0 : communicator->rank();
  const int size = communicator == nullptr ? 1 : communicator->size();
  fits->assign(count, LatentFitResult());
  seconds->assign(count, 0.0);
  for (int t : OwnedIndices(count, rank, size)) {
    WallTimer timer;
    LatentFitter fitter(model, options);
    fitter.set_bone_transforms(RestBoneTransforms(model));
    fitter.set_start_state(model.mesh.vertices);  // from rest: order-independent
    const FitTarget target = FullSurfaceTarget(surfaces[t]);
    LatentFitResult& fit = (*fits)[t];
    FitStartOptions start_options;
    start_options.training_poses = training_pose_starts;
    std::string failure;
    if (!FitFromChosenStart(&fitter, &target, nullptr, PointCloudFitOptions(), start_options,
                            fitter.MeanLatent(), &fit, &failure)) {
      // Left out of the evaluation (n/a), not the end of it: the other fits stand.
      fit = LatentFitResult();
      fit.failed = true;
      fit.start = kFailedFitStart;
      fit.message = "held-out pose '" + names[t] + "': " + failure;
    }
    if (fit.start == "given") fit.start = kMeanLatentStart;
    (*seconds)[t] = timer.Seconds();
  }
  if (size == 1) return;
  // Why each failed fit failed, from the rank that fitted it, for rank 0's log.
  for (int t = 0; t < count; ++t) {
    int failed = rank == t % size && (*fits)[t].failed ? 1 : 0;
    communicator->Broadcast(&failed, 1, t % size);
    if (!failed) continue;
    std::string message = (*fits)[t].message;
    communicator->BroadcastText(&message, t % size);
    (*fits)[t].message = message;
  }
  // Rank 0 gathers every fit: latent, bones, state, surface, errors, counts, seconds.
  const int d = model.latent_dim();
  const int nb = static_cast<int>(model.bones.size());
  const int nv = model.mesh.num_vertices();
  const int ns = model.num_surface_vertices();
  const int block = d + 12 * nb + 3 * nv + 3 * ns + 8;
  std::vector<double> send;
  for (int t : OwnedIndices(count, rank, size)) {
    const LatentFitResult& f = (*fits)[t];
    if (f.failed) {  // zeros in the block's place; the start index says it failed
      send.insert(send.end(), block - 8, 0.0);
      send.insert(send.end(), {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, (*seconds)[t], -2.0});
      continue;
    }
    send.insert(send.end(), f.latent.data(), f.latent.data() + d);
    for (const RigidTransform& b : f.bones) {
      send.insert(send.end(), b.rotation.data(), b.rotation.data() + 9);
      send.insert(send.end(), b.translation.data(), b.translation.data() + 3);
    }
    send.insert(send.end(), f.state.data(), f.state.data() + 3 * nv);
    send.insert(send.end(), f.surface.data(), f.surface.data() + 3 * ns);
    send.insert(send.end(), {f.rms_error, f.mean_error, f.max_error, double(f.iterations),
                             double(f.used_points), f.converged ? 1.0 : 0.0, (*seconds)[t],
                             double(StartIndex(model, f.start))});
  }
  std::vector<int> counts(size);
  for (int r = 0; r < size; ++r) {
    counts[r] = block * static_cast<int>(OwnedIndices(count, r, size).size());
  }
  std::vector<double> received(rank == 0 ? static_cast<size_t>(block) * count : 0);
  communicator->GatherToRoot(send.data(), counts, received.data());
  if (rank != 0) return;
  const double* x = received.data();
  for (int r = 0; r < size; ++r) {
    for (int t : OwnedIndices(count, r, size)) {
      LatentFitResult& f = (*fits)[t];
      f.latent = Eigen::Map<const Eigen::VectorXd>(x, d);
      x += d;
      f.bones.assign(nb, RigidTransform());
      for (RigidTransform& b : f.bones) {
        b.rotation = Eigen::Map<const Eigen::Matrix3d>(x);
        b.translation = Eigen::Map<const Eigen::Vector3d>(x + 9);
        x += 12;
      }
      f.state = Eigen::Map<const Eigen::Matrix3Xd>(x, 3, nv);
      x += 3 * nv;
      f.surface = Eigen::Map<const Eigen::Matrix3Xd>(x, 3, ns);
      x += 3 * ns;
      f.rms_error = x[0];
      f.mean_error = x[1];
      f.max_error = x[2];
      f.iterations = static_cast<int>(x[3]);
      f.used_points = static_cast<int>(x[4]);
      f.converged = x[5] != 0.0;
      (*seconds)[t] = x[6];
      f.start = StartName(model, static_cast<int>(x[7]));
      x += 8;
      if (f.start == kFailedFitStart) {
        const std::string message = f.message;
        f = LatentFitResult();
        f.failed = true;
        f.start = kFailedFitStart;
        f.message = message;
      }
    }
  }
}

}  // namespace aqs
