#ifndef AQS_JOBS_FIT_SEQUENCE_H_
#define AQS_JOBS_FIT_SEQUENCE_H_

#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dist/communicator.h"
#include "fit/latent_fit.h"
#include "jobs/sequence_frames.h"
#include "jobs/simulate_job.h"
#include "model/active_model.h"

namespace aqs {

// What aqs_fit --sequence does: fits an ordered sequence of targets frame after frame,
// each warm-started from the previous frame's latent, bones and equilibrium (the first
// from the start FitStartOptions chooses); or, without warm starts, every frame on its
// own, optionally shared among the ranks of an MPI job (docs/distributed.md).
struct FitSequenceOptions {
  std::string model;  // model directory (RunFitSequenceJob loads it)
  // The frames: a folder (its .obj, .txt and .ply files, sorted by name), a glob
  // (sorted), a .txt list (one path per line, in that order, relative to the list's
  // folder) or a comma-separated list (in that order).
  std::string sequence;
  std::string target_kind = "auto";  // as FitJobOptions::target_kind; one kind for all
  // Optional, sequences of point clouds (scans) only: one landmarks file per frame (a
  // markers file, "vertex x y z" lines: points whose vertex is known), listed as
  // `sequence` is (a folder's files by name, a glob, a .txt list or a comma list), the
  // k-th for the k-th frame; fitted with its scan (PointCloudFitOptions::landmarks,
  // weight points.landmark_weight).
  std::string landmarks;
  // Outputs (all atomic): <frame>.obj per frame (<frame>: the target's file name
  // without extension), frames.csv (one row per frame: errors, iterations, seconds,
  // where it started, stiffness factorizations (solves and Jacobians), latent, bone
  // motion), latents.bin (latent_dim x frames, util/matrix_io.h), key.txt (the model and
  // options) and targets.txt (per frame, its target's fingerprint). A frame is done when
  // its row is in frames.csv (written last) and its target is the one recorded when it was
  // fitted; a rerun resumes at the first frame not done.
  std::string output_dir;
  int max_frames = -1;  // < 0: all
  LatentFitOptions fit;
  PointCloudFitOptions points;
  FitStartOptions start;
  // true: each frame after the first starts from the previous frame's latent, bones and
  // equilibrium (the frame on which a resumed run starts: from the last frame done).
  // false: independent frames: every frame is fitted by a fitter of its own from the
  // start `start` chooses for it (as the first frame is), so that a frame's result
  // depends on nothing but its target (not on the order, the previous frame or the rank
  // that fits it); frames.csv's `start` column names that start for every frame.
  bool warm_start = true;
  // With warm starts, frames after the first are also pulled toward the previous frame's
  // latent and bone motions (LatentFitter::SetTemporalPrior's weight: squared length per
  // target point per standard deviation of the training spread, as the priors' weights;
  // on a resumed run, toward the last frame done). Damps the jitter of noisy markers.
  // 0: off. Needs warm_start (independent frames have no previous frame).
  double temporal_prior = 0.0;
  // The ranks that share the frames (null, or one rank: one process). Needs
  // warm_start = false with more than one rank (else kBadInput on every rank). Frames
  // are fitted in rounds of size() frames, frame first + k on rank k; rank 0 gathers
  // their results and alone writes every output, after each round: the outputs are
  // those of one process, byte for byte, except the seconds column of frames.csv.
  // Collective: every rank calls RunFitSequence(Job) with the same options.
  const Communicator* communicator = nullptr;

  // Checks the values (target_kind, fit, points, max_frames); false with *error naming
  // the first bad one (util/option_checks.h). The paths are checked as they are read.
  bool Validate(std::string* error) const;
};

struct FitSequenceResult {
  JobStatus status = JobStatus::kOk;
  std::string message;
  std::vector<std::string> frame_names;  // all frames, in order
  int frames_fitted = 0;   // written in this run (every rank: all ranks' frames)
  int frames_failed = 0;   // of those, independent frames that could not be fitted
  int frames_resumed = 0;  // found done in output_dir
  double seconds = 0.0;    // fitting time of this run (after reading the targets)
  double frames_per_second = 0.0;
};

// Fits the frames with `model` (which must be the one options.model names, for the
// messages; with ranks, the same model on every rank) and writes the outputs. Progress
// lines with frames per second and an ETA go to `log` (rank 0's; the other ranks log
// nothing). With warm starts, a frame that cannot be fitted (its equilibrium cannot be
// computed, or no start reaches it) stops the sequence there (kNotConverged). Independent
// frames go on past it: it gets a row with converged -1 and no OBJ
// (jobs/sequence_outputs.h), the others are fitted and written, and the result is then
// kNotConverged, its message counting such frames (with those of an earlier run the
// folder holds; a warm-started rerun fits them again). With ranks, a failure on any
// rank (bad input, an output that cannot be written, a warm-started frame) stops every
// rank with the same status and message (the first failing frame's); every rank returns
// the same result.
FitSequenceResult RunFitSequence(const FitSequenceOptions& options, const ActiveModel& model,
                                 std::ostream& log);

// Loads options.model (with ranks: on every rank, checked and shared from rank 0's,
// dist/model_sharing.h), then RunFitSequence.
FitSequenceResult RunFitSequenceJob(const FitSequenceOptions& options, std::ostream& log);

}  // namespace aqs

#endif  // AQS_JOBS_FIT_SEQUENCE_H_
