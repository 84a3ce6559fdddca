#ifndef AQS_JOBS_LEARNING_JOBS_H_
#define AQS_JOBS_LEARNING_JOBS_H_

#include <ostream>
#include <string>
#include <vector>

#include "dist/communicator.h"
#include "eval/error_budget.h"
#include "train/pretrain.h"
#include "train/trainer.h"

namespace aqs {

// aqs_pretrain as a library call: takes the model's writers' lock
// (model/model_directory.h; it fails with "model DIR is in use by process PID" while
// another process writes the model), loads the model directory, pre-trains a new
// decoder and latents (train/pretrain.h), and saves the model (any earlier training
// checkpoint, states and log are discarded: they belong to the old decoder). Pre-training
// checkpoints go to the model's pretrain/ folder (options.checkpoint_directory is
// replaced by it; train/solver_checkpoint.h): a killed run, run again with the same
// options and options.resume, continues from the last one; saving the model removes
// them. With
// `simulation` (may be null: skipped), every pose's pre-trained latent is then decoded
// and simulated from rest: the surface errors, stage (b) of the error budget
// (eval/error_budget.h), are logged per pose next to the embedding floor and written to
// pretrain/surface_errors.* in the model directory, and the equilibria are saved as the
// states that end-to-end training starts from (it would solve the same equilibria from
// rest first). A pose that does not converge is reported, and gets no state.
// Invalid options (Validate) and a memory estimate above options.max_memory_bytes
// (PretrainMemoryBytes) fail before the model is touched; messages start with the
// options' field names ("spec.latent_dim ...", "simulation.solver.num_threads ...").
// At the end it writes the record pretrain/key.txt (kPretrainRecordName,
// jobs/pretrain_record.h): the checkpoint key (PretrainCheckpointKey), the budget,
// whether the poses were simulated, and whether it stalled with every restart used.
// With keep_pretrained, a model whose decoder has the record of this pre-training (the
// same model, targets, options, budget and simulation; a stall with fewer restarts than
// options.max_restarts only if trained since, with a note) is kept as it is, with any
// training since, and nothing is written (aqs_pipeline, so that a rerun
// after a stop goes on where it stopped); a decoder pre-trained otherwise (or without a
// record) and trained since is not replaced: the job fails saying so.
// With `communicator` spanning several ranks (aqs_pipeline under MPI), every rank calls
// it with the same simulation options: rank 0 does the job, and the simulation of every
// pose is shared among the ranks (jobs/shared_pose_work.h; the model travels from rank 0,
// dist/model_broadcast.h); the other ranks use only `simulation`, read and write
// nothing, and return false only if the model cannot reach them (*error then on every
// rank); rank 0's status is the job's.
bool RunPretrainJob(const std::string& model_directory, const PretrainOptions& options,
                    const PoseSimulationOptions* simulation, std::ostream& log,
                    std::string* error, bool keep_pretrained = false,
                    const Communicator* communicator = nullptr);

// The record of a finished pre-training in the model's pretrain/ folder.
inline constexpr char kPretrainRecordName[] = "key.txt";

// Where pre-trainings of the model at model_directory keep the checkpoints of other
// runs they do not resume (PretrainOptions::kept_checkpoints_directory): beside the
// model, MODEL.aqs-pretrain-kept (a folder of the model's own would make it no model).
std::string KeptPretrainCheckpointsPath(const std::string& model_directory);

// What the caller of RunTrainJob expects of the model's decoder (aqs_train's
// --latent_dim, --hidden and --activation when given): training cannot change the
// architecture, so a mismatch is an error rather than a silently ignored flag.
// 0, empty: anything.
struct ExpectedDecoder {
  int latent_dim = 0;
  std::vector<int> hidden_dims;
  std::string activation;  // "elu", "tanh", "softplus" or empty
};

// aqs_train as a library call: takes the model's writers' lock, loads the pre-trained
// model and trains it end to end (train/trainer.h) with checkpoints in the model
// directory, resuming after the checkpoint's iterations. With restart, the checkpoint's
// count is reset to 0 first (the iterations and the log start again; the learned state
// in the directory is still the starting point). At the end it logs the training poses'
// error budget over all surface vertices (TrainingBudgetTable): embedding floor, after
// pre-training (if the model directory has the record), and after training.
//
// With options.communicator spanning several ranks, every rank calls it with the same
// arguments (docs/distributed.md): rank 0 takes the lock, loads the model and logs;
// the others load the model too once rank 0 holds the lock (ShareModel: it must be the
// same model; rank 0's learned state is used) and never write it. Every rank returns
// the same status; *error is set on every rank for failures before training (naming the
// rank that failed) and on rank 0 for the others.
// Invalid options (TrainOptions::Validate) fail before the model is touched; a decoder
// other than `expected` fails after loading it, before training.
bool RunTrainJob(const std::string& model_directory, const TrainOptions& options, bool restart,
                 std::ostream& log, std::string* error,
                 const ExpectedDecoder& expected = ExpectedDecoder());

}  // namespace aqs

#endif  // AQS_JOBS_LEARNING_JOBS_H_
