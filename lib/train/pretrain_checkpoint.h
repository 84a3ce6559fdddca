#ifndef AQS_TRAIN_PRETRAIN_CHECKPOINT_H_
#define AQS_TRAIN_PRETRAIN_CHECKPOINT_H_

#include <string>

#include <Eigen/Core>
#include <ceres/iteration_callback.h>

#include "model/active_model.h"
#include "train/pretrain.h"
#include "util/wall_timer.h"

namespace aqs {

// Pre-training checkpoints, so that a killed pre-training resumes where it was
// (PretrainOptions::checkpoint_directory; in a model directory, pretrain/):
//
//   checkpoint.txt     "model <fingerprint>", "targets <hash>", "options <text>",
//                      "iterations N", "seconds S", "loss L",
//                      "parameters <file> <count>"
//   parameters_a.bin   one of two slots, written in turn (util/matrix_io.h, count x 1:
//   parameters_b.bin   the decoder's parameters, then the latents column by column)
//
// A checkpoint is written into the slot checkpoint.txt does not name, then
// checkpoint.txt (atomically) names it: a process killed at any moment leaves a whole
// checkpoint, the old or the new one.

// What a checkpoint's parameters belong to: the model as prepared (ModelFingerprint),
// its volumetric targets (a hash of their numbers), and every option that shapes the
// decoder or the loss (spec, field, latent start, regularizers, seed). Not the budget
// (iterations, time), threads or memory limit: a resumed run may change those.
struct PretrainCheckpointKey {
  std::string model;
  std::string targets;
  std::string options;
};

PretrainCheckpointKey MakePretrainCheckpointKey(const PretrainOptions& options,
                                                const ActiveModel& model);

struct PretrainCheckpoint {
  PretrainCheckpointKey key;
  int iterations = 0;     // L-BFGS iterations done, in all runs
  double seconds = 0.0;   // wall time spent in them, in all runs
  double loss = 0.0;      // the pre-training loss at `parameters`
  Eigen::VectorXd parameters;
};

// Reads the checkpoint in `directory` if there is one that belongs to `key` with
// `num_parameters` parameters. Returns true with *checkpoint filled if so. Returns false
// with *why_not empty if there is no checkpoint, or saying why the one there is not
// used ("it belongs to other options: ...", a damaged file named with its line).
bool ReadPretrainCheckpoint(const std::string& directory, const PretrainCheckpointKey& key,
                            int num_parameters, PretrainCheckpoint* checkpoint,
                            std::string* why_not);

// Writes `checkpoint` into `directory` (created if missing) as described above.
// Returns false with *error on failure (the checkpoint there before is kept).
bool WritePretrainCheckpoint(const std::string& directory, const PretrainCheckpoint& checkpoint,
                             std::string* error);

// A Ceres iteration callback that writes a checkpoint of the solver's current point
// (the array `parameters` of `num_parameters`, which the solver must update every
// iteration: update_state_every_iteration) at most every `every_seconds` seconds
// (0: every iteration), counting iterations and time after `start`'s. A failed write
// stops the solver (SOLVER_ABORT, error() says why): work that cannot be kept is not
// done. Write() writes the point reached (at the end of a solve).
class PretrainCheckpointWriter final : public ceres::IterationCallback {
 public:
  PretrainCheckpointWriter(std::string directory, const PretrainCheckpoint& start,
                           double every_seconds, const double* parameters, int num_parameters);
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override;
  bool Write(int iterations, double loss);
  const std::string& error() const { return error_; }
  int checkpoints() const { return checkpoints_; }

 private:
  std::string directory_;
  PretrainCheckpoint checkpoint_;
  double every_seconds_;
  const double* parameters_;
  int num_parameters_;
  int start_iterations_;
  double start_seconds_;
  WallTimer run_timer_;
  WallTimer since_write_;
  int checkpoints_ = 0;
  std::string error_;
};

}  // namespace aqs

#endif  // AQS_TRAIN_PRETRAIN_CHECKPOINT_H_
