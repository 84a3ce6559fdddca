#ifndef AQS_JOBS_HELD_OUT_FITS_H_
#define AQS_JOBS_HELD_OUT_FITS_H_

// aqs_evaluate's latent fits of held-out poses: the physics model's (shared among the
// ranks of a distributed run) and the start of the auto-encoder's.

#include <string>
#include <vector>

#include <Eigen/Core>

#include "eval/surface_autoencoder.h"
#include "fit/latent_fit.h"
#include "model/active_model.h"

namespace aqs {

class Communicator;

// How the report names the start at the mean training latent.
constexpr char kMeanLatentStart[] = "mean latent";

// The start of the auto-encoder's latent fit to `truth` (3 x N, every surface vertex):
// its mean training latent or, with training_pose_starts, whichever of that
// and its trained latents (in the order of model.poses) has the smallest FitLatent
// objective (1/N) sum_v |surface_v(z) - y_v|^2 + lambda |z|^2. *name: "mean latent" or
// the pose's name.
Eigen::VectorXd AutoencoderStart(const SurfaceAutoencoder& autoencoder, const ActiveModel& model,
                                 const Eigen::Matrix3Xd& truth, bool training_pose_starts,
                                 std::string* name);

// The physics fits of the held-out poses (names; surfaces: 3 x num_surface_vertices
// each), each with a fitter of its own, from the mean training latent at rest or, with
// training_pose_starts, from the best of that and the training poses
// (LatentFitResult::start names it, kMeanLatentStart for the mean latent). Shared among
// the ranks of `communicator` (null: one process): pose t is fitted by rank t % size,
// and rank 0 receives every result (*fits, *seconds: each fit's wall time on its rank).
// A fit that fails (no start can be simulated, or its solve fails) does not stop the
// others: its result has failed = true, message = why ("held-out pose 'x': ..."), start
// kFailedFitStart and no surface or state; the evaluation leaves it out (n/a).
// Collective: every rank calls it with the same arguments.
void FitHeldOutPoses(const ActiveModel& model, const LatentFitOptions& options,
                     bool training_pose_starts, const std::vector<std::string>& names,
                     const std::vector<Eigen::Matrix3Xd>& surfaces,
                     const Communicator* communicator, std::vector<LatentFitResult>* fits,
                     std::vector<double>* seconds);

// LatentFitResult::start of a held-out fit that failed.
inline constexpr const char* kFailedFitStart = "failed";

}  // namespace aqs

#endif  // AQS_JOBS_HELD_OUT_FITS_H_
