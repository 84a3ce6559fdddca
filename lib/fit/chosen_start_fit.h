#ifndef AQS_FIT_CHOSEN_START_FIT_H_
#define AQS_FIT_CHOSEN_START_FIT_H_

#include <string>
#include <vector>

#include <Eigen/Core>

#include "fit/latent_fit.h"

namespace aqs {

// Whether bone motions (one per bone of `prior`, in the model's bone order) lie beyond
// the training poses': for some bone, the Mahalanobis distance of its 6 fit parameters
// under the bone prior exceeds both 1 (one standard deviation) and that of every
// training pose's motion of that bone (model_bones[b].pose_transforms). Bones without
// training motions never count.
bool BonesBeyondTrainingPoses(const FitPrior& prior, const std::vector<Bone>& model_bones,
                              const std::vector<RigidTransform>& bones);

// Fits `fitter` to a target (non-null `target`: LatentFitter::Fit) or a point cloud
// (non-null `points`, 3 x M: FitPointCloud) from the start LatentFitter::ChooseStart
// picks among `given` (latent_dim; with the fitter's current bone transforms and start
// state) and the training poses. With options.retry_from_given, a fit from a training
// pose that fails, does not converge or ends with bones beyond the training poses'
// (BonesBeyondTrainingPoses) is fitted again from the given start, and the fit of the
// smaller LatentFitter::StartObjective is kept; its counters then sum both fits,
// result->retry_reason says why the retry ran and result->retry_kept whether it was
// kept. result->start names the kept fit's start ("given" or a training pose). The
// fitter is left at the kept fit (its bones; its equilibrium as the next start). Returns
// false with *error when no start can be simulated (result->start then stays empty) or
// every fit that ran failed (result then holds the failed fit, as Fit leaves it).
bool FitFromChosenStart(LatentFitter* fitter, const FitTarget* target,
                        const Eigen::Matrix3Xd* points, const PointCloudFitOptions& cloud_options,
                        const FitStartOptions& options, const Eigen::VectorXd& given,
                        LatentFitResult* result, std::string* error);

}  // namespace aqs

#endif  // AQS_FIT_CHOSEN_START_FIT_H_
