#ifndef AQS_TRAIN_PRETRAIN_H_
#define AQS_TRAIN_PRETRAIN_H_

#include <ostream>
#include <string>

#include "learn/decoder.h"
#include "learn/grid_actuation_field.h"
#include "model/active_model.h"
#include "train/solver_checkpoint.h"
#include "util/memory_limit.h"

namespace aqs {

// Where pre-training's latents start, and whether it moves them.
//   kTargets:  the whitened principal-component scores of the volumetric targets
//              (about their mean, volume-weighted); pre-training fits them together
//              with the decoder.
//   kSurfaces: the whitened principal-component scores of the pose surfaces'
//              displacements from the neutral (uncentered, as the evaluation's PCA
//              about the neutral; the neutral pose scores zero), held fixed: pre-training
//              fits the decoder alone, so that it maps the surfaces' principal
//              coordinates to actuations. End-to-end training then moves both. (The
//              targets' own components follow the strain in the volume, where the lids'
//              small motions weigh as much as the jaw's; the surfaces' follow what the
//              training loss measures.)
enum class PretrainLatentStart { kTargets, kSurfaces };

// "targets", "surfaces" (flag values).
const char* PretrainLatentStartName(PretrainLatentStart start);
// Inverse of PretrainLatentStartName. Returns false for an unknown name.
bool PretrainLatentStartFromName(const std::string& name, PretrainLatentStart* start);

// Pre-training's CSV log in the checkpoint directory (with checkpoints only), while it
// runs: one row per iteration, kPretrainLogHeader's fields, row 0 the start (a resumed
// run continues the rows up to its checkpoint). RunPretrainJob copies it into the model
// it saves as kPretrainLogName: a model's pretrain/log.csv is always that of its own
// decoder, also while another pre-training runs in its folder or after one was stopped.
inline constexpr char kPretrainRunLogName[] = "run_log.csv";
inline constexpr char kPretrainLogName[] = "log.csv";
inline constexpr char kPretrainLogHeader[] = "iteration,loss,gradient_norm,seconds\n";

struct PretrainOptions {
  DecoderSpec spec;                 // latent dimension, layers, activation, output scale
  GridActuationFieldOptions field;  // the decoder's output grid
  PretrainLatentStart latent_start = PretrainLatentStart::kTargets;
  // Weight of the latent regularizer (1/P) sum_p |z_p|^2.
  double latent_regularization = 1e-3;
  // Weight of the decoder regularizer |params|^2 (weight decay; TrainOptions'). 0: none.
  double decoder_regularization = 0.0;
  int max_iterations = 500;
  // L-BFGS restarts from the accepted point, with an empty memory, allowed where a
  // solve stalls before max_iterations: the rule and default of end-to-end training
  // (TrainOptions::max_restarts, train/lbfgs_restarts.h).
  int max_restarts = 50;
  // Stop (successfully, keeping the point reached) once this much wall time was spent
  // in the L-BFGS iterations (0: no limit): its tolerances are seldom reached, and a
  // long pre-training keeps nothing until it ends.
  double max_seconds = 0.0;
  unsigned seed = 1;
  // Checkpoints (train/solver_checkpoint.h, PretrainCheckpointKey) and the CSV log
  // (kPretrainRunLogName) go into this folder (empty: none; in a model directory,
  // pretrain/), checkpoints at most every checkpoint_seconds of iterations (0: every
  // iteration) and at the end. With resume, a checkpoint there that belongs to this
  // model, its targets and these options is the start: its iterations and time count
  // towards max_iterations and max_seconds.
  std::string checkpoint_directory;
  // A run that starts anew keeps the checkpoint it does not resume (another run's, of
  // other options or a --restart) in this folder, one per key (MoveSolverCheckpointAside;
  // empty: it is removed), and a run whose key one of them has takes it back and resumes
  // it (RestoreKeptCheckpoint). Outside the model: a model's, MODEL.aqs-pretrain-kept.
  std::string kept_checkpoints_directory;
  double checkpoint_seconds = 60.0;
  bool resume = true;
  // Progress line every this many iterations (0: none).
  int log_every = 25;
  // Memory limit (bytes): Pretrain estimates the decoder, its L-BFGS history and the
  // batch before allocating (PretrainMemoryBytes), and fails with the estimate above it.
  double max_memory_bytes = kDefaultMaxMemoryBytes;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

struct PretrainReport {
  int iterations = 0;         // in all runs (iterations_before included)
  int iterations_before = 0;  // done by earlier runs (from the checkpoint)
  int checkpoints = 0;        // written by this run
  int restarts = 0;           // L-BFGS restarts after a stall, in this run
  // The run ended where L-BFGS stalled before the budget with every restart allowed
  // (max_restarts) used: with more allowed, pre-training could go further.
  bool stalled_without_restarts = false;
  double initial_loss = 0.0;
  double final_loss = 0.0;
  // sqrt of the volume-weighted mean squared actuation error |a - S|_F^2 over poses
  // and elements, at the end (in strain units: 0.01 = 1%).
  double rms_actuation_error = 0.0;
  double seconds = 0.0;  // this run's
  std::string termination;
};

// What a pre-training checkpoint belongs to: the model as prepared ("model":
// ModelFingerprint), its volumetric targets ("targets": a hash of their numbers) and
// every option that shapes the decoder or the loss ("options": spec, field, latent start,
// regularizers, seed), not the budget, threads or memory limit.
CheckpointKey PretrainCheckpointKey(const PretrainOptions& options, const ActiveModel& model);

// The memory Pretrain needs for `model` with `options`, planned before anything is
// allocated: the decoder (learn/decoder.h, DecoderMemoryBytes, for a batch of all
// poses), the L-BFGS history and work vectors (48 arrays of parameters and latents) and
// the targets' copies (4 x 48 bytes per element and pose). *details (may be null) says
// what the estimate is made of. Returns false with *error if the decoder cannot be
// planned: a control grid too fine for the mesh ("field.node_spacing ...") or more
// parameters than an int holds ("spec.hidden_dims ...").
bool PretrainMemoryBytes(const PretrainOptions& options, const ActiveModel& model, double* bytes,
                         std::string* details, std::string* error);

// Pre-training: a supervised fit of a new decoder and one latent per pose to the
// model's volumetric targets (an auto-decoder; equivalent to training an auto-encoder
// and keeping its decoder and codes):
//
//   min over params, z_1..z_P of  (1/P) sum_p sum_e w_e |a_e(z_p) - S_pe|_F^2
//                                 + latent_regularization (1/P) sum_p |z_p|^2
//                                 + decoder_regularization |params|^2,
//
// with w_e = V_e / sum V (|.|_F the Frobenius norm of the 3x3 matrices), by Ceres'
// L-BFGS (GradientProblemSolver; restarted where it stalls before max_iterations, up to
// max_restarts times, as end-to-end training's is: RunLbfgsWithRestarts, which also keeps
// the result at the last accepted point). Latents start as options.latent_start says (with
// kSurfaces they stay there), parameters at random (small outputs); or, with a
// checkpoint to resume (options.checkpoint_directory, resume), at the checkpoint's point,
// with the rest of the budget (L-BFGS' history starts anew there). Every pose needs a
// target. A checkpoint that cannot be written stops pre-training with the error.
// Sets model->decoder, decoder_params and latents, and clears the states, the training
// checkpoint and the fits' prior (they belonged to the old decoder; fits learn the prior
// from the new latents, as a save does). Progress lines go to `log`.
// Fails with *error, before allocating, on invalid options (options.Validate) and on
// an estimate (PretrainMemoryBytes) above options.max_memory_bytes.
bool Pretrain(const PretrainOptions& options, ActiveModel* model, PretrainReport* report,
              std::ostream& log, std::string* error);

}  // namespace aqs

#endif  // AQS_TRAIN_PRETRAIN_H_
