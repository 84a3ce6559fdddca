#ifndef AQS_JOBS_HELD_OUT_FITS_H_
#define AQS_JOBS_HELD_OUT_FITS_H_

// aqs_evaluate's latent fits of held-out poses: the physics model's (shared among the
// ranks of a distributed run) and the start of the auto-encoder's.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "eval/surface_autoencoder.h"
#include "fit/latent_fit.h"
#include "jobs/held_out_fit_store.h"
#include "model/active_model.h"

namespace aqs {

class Communicator;

// The start of the auto-encoder's latent fit to `truth` (3 x N, every surface vertex)
// with the fit options `fit` (the physics fits'): its mean training latent or, with
// training_pose_starts, whichever of that and its trained latents (in the order of
// model.poses) has the smallest FitLatent objective (1/N) sum_v |surface_v(z) - y_v|^2 +
// FitPriorTerm(z, N, fit). *name: "mean latent" or the pose's name.
Eigen::VectorXd AutoencoderStart(const SurfaceAutoencoder& autoencoder, const ActiveModel& model,
                                 const Eigen::Matrix3Xd& truth, const LatentFitOptions& fit,
                                 bool training_pose_starts, std::string* name);

// The physics fits of the held-out poses, per pose in the order given.
struct HeldOutFits {
  std::vector<LatentFitResult> fits;
  std::vector<double> seconds;  // each fit's wall time on its rank (a kept fit: its own)
  int kept = 0;                 // fits taken from the store (a stopped run's)
  // Why the store could not be opened or a fit not kept ("" if all went well): the fits
  // stand, but a stopped run would do them again.
  std::string store_warning;
};

// The physics fits of the held-out poses (names; surfaces: 3 x num_surface_vertices
// each), each with a fitter of its own, from the mean training latent at rest or, with
// training_pose_starts, from the best of that and the training poses
// (LatentFitResult::start names it, kMeanLatentStart for the mean latent). Shared among
// the ranks of `communicator` (null: one process): pose t is fitted by rank t % size,
// and rank 0 receives every result into *out (the other ranks: their own).
// A fit that fails (no start can be simulated, or its solve fails) does not stop the
// others: its result has failed = true, message = why ("held-out pose 'x': ..."), start
// kFailedFitStart and no surface or state; the evaluation leaves it out (n/a).
// With store_directory (non-empty), rank 0 keeps every fit there as it gets it
// (jobs/held_out_fit_store.h, keyed by HeldOutFitKey) and takes the fits found there
// for this model, its learned state, these options and the same pose name and surface
// instead of fitting them again: a rerun after a stop goes on where it stopped, with
// the same results. Collective: every rank calls it with the same arguments.
void FitHeldOutPoses(const ActiveModel& model, const LatentFitOptions& options,
                     bool training_pose_starts, const std::vector<std::string>& names,
                     const std::vector<Eigen::Matrix3Xd>& surfaces,
                     const std::string& store_directory, const Communicator* communicator,
                     HeldOutFits* out);

}  // namespace aqs

#endif  // AQS_JOBS_HELD_OUT_FITS_H_
