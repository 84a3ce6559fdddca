#ifndef AQS_JOBS_SHARED_POSE_WORK_H_
#define AQS_JOBS_SHARED_POSE_WORK_H_

#include <ostream>
#include <string>
#include <vector>

#include "dist/communicator.h"
#include "eval/error_budget.h"
#include "model/active_model.h"
#include "prepare/volumetric_targets.h"

namespace aqs {

// The per-pose work of prepare and pre-training, shared among the ranks of a distributed
// run (docs/distributed.md): every rank holds rank 0's model (dist/model_broadcast.h),
// each pose is worked on by one rank, and the results go to rank 0, which alone logs them
// and writes. With one rank, the work of one process.

// MakeVolumetricTargets with the poses shared among the ranks of `comm`. Collective: every
// rank calls it with the same options (num_threads: the rank's own) and rank 0's model.
// Rank 0 alone uses options.store_directory: it takes the poses found there (as one
// process does). The poses still to be made are made in rounds: in each, every rank
// makes as many as the ranks' fewest options.num_threads (VolumetricTargetMaker, its
// solvers kept between rounds), and rank 0 keeps its own in the store as they are made
// and the other ranks' at the end of the round, before the next starts (a kill loses at
// most the round under way; a round waits for its slowest pose). Rank 0's model then
// has every pose's target and errors, rank 0's `log` every rank's lines (the other
// ranks' at the end of each round), and *unconverged (rank 0's; may be null) the
// messages of the poses whose solve did not converge, as MakeVolumetricTargets gives
// them. Returns the same on every rank: false
// with *error for invalid options (Validate; naming the rank), a store rank 0 cannot
// open, or, with `unconverged` null on rank 0, the first pose that did not converge.
bool MakeVolumetricTargetsOnRanks(const Communicator& comm,
                                  const VolumetricTargetOptions& options, ActiveModel* model,
                                  std::ostream& log, std::string* error,
                                  std::vector<std::string>* unconverged);

// Every training pose of `model` (decoder set) simulated from rest with its pre-trained
// latent decoded and its bones (SimulateActuations of DecodeTrainingLatents), pose p on
// rank p % size of `comm`. Collective: every rank calls it with the same options and
// rank 0's model. Rank 0 returns every pose's result (num_poses entries, the same as one
// process computes: a pose's simulation depends on nothing else), the other ranks an
// empty vector.
std::vector<SimulatedPose> SimulateTrainingPosesOnRanks(const Communicator& comm,
                                                        const ActiveModel& model,
                                                        const PoseSimulationOptions& options);

}  // namespace aqs

#endif  // AQS_JOBS_SHARED_POSE_WORK_H_
