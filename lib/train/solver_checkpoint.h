#ifndef AQS_TRAIN_SOLVER_CHECKPOINT_H_
#define AQS_TRAIN_SOLVER_CHECKPOINT_H_

#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <ceres/iteration_callback.h>

#include "util/wall_timer.h"

namespace aqs {

// Checkpoints of a Ceres GradientProblemSolver run (pre-training, the auto-encoder
// baseline), so that a killed run resumes where it was. A folder:
//
//   checkpoint.txt     "key <name> <value>" per key entry, "iterations N", "seconds S",
//                      "loss L", "parameters <file> <count>"
//   parameters_a.bin   one of two slots, written in turn (util/matrix_io.h, count x 1:
//   parameters_b.bin   the solver's parameter vector)
//
// A checkpoint is written into the slot checkpoint.txt does not name, then
// checkpoint.txt (atomically) names it: a process killed at any moment leaves a whole
// checkpoint, the old or the new one.

// What a checkpoint's parameters belong to: named values (names without spaces, values
// on one line) that must all be equal for the checkpoint to be resumed: what the data
// and the options that shape the result are, not the budget (iterations, time),
// threads or memory limit, which a resumed run may change.
using CheckpointKey = std::vector<std::pair<std::string, std::string>>;

struct SolverCheckpoint {
  CheckpointKey key;
  int iterations = 0;     // iterations done, in all runs
  double seconds = 0.0;   // wall time spent in them, in all runs
  double loss = 0.0;      // the objective at `parameters`
  Eigen::VectorXd parameters;
};

// Reads the checkpoint in `directory` if there is one that belongs to `key` with
// `num_parameters` parameters. Returns true with *checkpoint filled if so. Returns false
// with *why_not empty if there is no checkpoint, or saying why the one there is not
// used ("'options' differs (saved; now)", a damaged file named with its line).
bool ReadSolverCheckpoint(const std::string& directory, const CheckpointKey& key,
                          int num_parameters, SolverCheckpoint* checkpoint,
                          std::string* why_not);

// Whether `loss`, the objective evaluated at a resumed checkpoint's parameters, is the
// loss the checkpoint recorded there, `recorded`: both finite and equal to 1e-6 of their
// size (the same objective in another run can differ in its last digits, with other
// threads). A checkpoint whose finite numbers give another loss is damaged.
bool SameLoss(double loss, double recorded);

// Checkpoints of other runs kept in `kept_root` (a folder outside any model: a run that
// starts anew does not destroy the one it does not resume, and a run of that one's key
// takes it back). One folder per key: kept_root/<KeptCheckpointName(key)>/ holds that
// checkpoint's checkpoint.txt, its slot and the files `also` names (such as the run's
// log); at most kMaxKeptCheckpoints, the oldest removed first.
inline constexpr int kMaxKeptCheckpoints = 3;

// The folder name of a key's kept checkpoint: 16 hexadecimal digits of a hash of its key
// lines.
std::string KeptCheckpointName(const CheckpointKey& key);

// Moves the checkpoint in `directory` (checkpoint.txt, the slot it names, and the files
// `also` names in `directory`) into kept_root/<its key's name>/, replacing an earlier
// one of the same key. Copies into <that>.tmp first, syncs, renames, then removes
// checkpoint.txt: a kill at any moment leaves the checkpoint whole in one of the two
// places. True with *moved false if there is no checkpoint.txt. False with *error if a
// file cannot be copied or removed (the checkpoint then stays where it was).
bool MoveSolverCheckpointAside(const std::string& directory, const std::string& kept_root,
                               const std::vector<std::string>& also, bool* moved,
                               std::string* error);

// Removes the checkpoint kept for `key` in kept_root and a staging folder of it left by
// a stopped move (a run that resumes the same key's checkpoint from its own folder: a
// move killed after its rename left the checkpoint in both places, and the kept copy
// would be taken back by a later run instead of starting anew). True, with *removed
// saying whether there was one, when none is left; false with *error if a folder cannot
// be removed.
bool RemoveKeptCheckpoint(const std::string& kept_root, const CheckpointKey& key,
                          bool* removed, std::string* error);

// Takes back into `directory` (which must hold no checkpoint.txt) the checkpoint kept
// for `key` in kept_root, if there is one: its slot and `also` files are copied first,
// its checkpoint.txt last (atomically), then its kept folder is removed. True with
// *restored false if none is kept for the key. False with *error if a file cannot be
// copied (the kept one stays).
bool RestoreKeptCheckpoint(const std::string& directory, const std::string& kept_root,
                           const CheckpointKey& key, const std::vector<std::string>& also,
                           bool* restored, std::string* error);

// Removes the checkpoint in `directory` (its checkpoint.txt; the slots, which nothing then
// names, stay for the next write). True if there is none. False with *error if it
// cannot be removed.
bool RemoveSolverCheckpoint(const std::string& directory, std::string* error);

// Writes `checkpoint` into `directory` (created if missing) as described above.
// Returns false with *error on failure (the checkpoint there before is kept).
bool WriteSolverCheckpoint(const std::string& directory, const SolverCheckpoint& checkpoint,
                           std::string* error);

// A Ceres iteration callback that writes a checkpoint of the solver's current point
// (the array `parameters` of `num_parameters`, which the solver must update every
// iteration: update_state_every_iteration) at most every `every_seconds` seconds
// (0: every iteration), counting iterations and time after `start`'s. A failed write
// stops the solver (SOLVER_ABORT, error() says why): work that cannot be kept is not
// done. Write() writes the point reached (at the end of a solve).
class SolverCheckpointWriter final : public ceres::IterationCallback {
 public:
  SolverCheckpointWriter(std::string directory, const SolverCheckpoint& start,
                         double every_seconds, const double* parameters, int num_parameters);
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override;
  bool Write(int iterations, double loss);
  const std::string& error() const { return error_; }
  int checkpoints() const { return checkpoints_; }

 private:
  std::string directory_;
  SolverCheckpoint checkpoint_;
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

#endif  // AQS_TRAIN_SOLVER_CHECKPOINT_H_
