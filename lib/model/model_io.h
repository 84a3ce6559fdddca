#ifndef AQS_MODEL_MODEL_IO_H_
#define AQS_MODEL_MODEL_IO_H_

#include <functional>
#include <string>

#include "model/active_model.h"

namespace aqs {

// A model is a directory (docs/model_format.md), format 2:
//
//   model.txt         manifest: format version and counts (text)
//   mesh.mesh         simulation tet mesh at rest (MEDIT)
//   mu.bin            stiffness per element (1 x num_elements)
//   fixed.txt         fixed vertices, "vertex bone" per line (bone -1: static at rest)
//   bones.txt         "bone <b> <name>", then "<b> <pose> r00 r01 r02 r10 r11 r12 r20 r21 r22
//                     t0 t1 t2" per training pose
//   neutral.obj       the neutral surface
//   embedding.txt     per surface vertex: "element w0 w1 w2 w3 ox oy oz outside_distance"
//   poses.txt         per training pose: "<index> <name> <mean error> <max error>"
//   poses/NNNN.bin    pose surfaces (3 x num_surface_vertices)
//   targets/NNNN.bin  volumetric targets (6 x num_elements), where made
//   learned/          the learned state, replaced as one unit (once pre-trained):
//     decoder.txt       the decoder (learn/decoder.h)
//     latents.bin       latent_dim x num_poses
//     states/NNNN.bin   last equilibrium per pose (3 x num_vertices), where known
//     prior.txt         the fits' priors (model/fit_prior.h)
//     checkpoint.txt    "iterations N" and "loss L": the model's TrainingCheckpoint
//   pretrain/surface_errors.bin, .txt   what pre-training reached (eval/error_budget.h)
//   pretrain/log.csv  pre-training's log (train/pretrain.h); while it runs also its
//                     checkpoint (train/solver_checkpoint.h) and its log run_log.csv
//   train/log.csv     end-to-end training log (train/trainer.h)
//
// Binary files use util/matrix_io.h. NNNN is the zero-padded pose index. Format 1 had
// decoder.txt, latents.bin and states/ at the top and the checkpoint in
// train/checkpoint.txt; it is still read, and rewritten as format 2 by the next save.
//
// Writers hold the model's lock (model/model_directory.h); SaveModel and
// SaveLearnedState take it themselves if the caller does not hold it already.

struct SaveModelOptions {
  // Replace whatever is at the directory; without it only a missing path, an empty
  // directory or an ActiveQS model is replaced (CheckModelDestination).
  bool overwrite = false;
  // Carry the records of the model being replaced over: the training log
  // (train/log.csv) and the pre-training record (pretrain/log.csv, surface_errors.*,
  // key.txt; eval/error_budget.h), not pre-training's checkpoint.
  bool keep_records = false;
  // Writes further files into the new model's staging directory (its argument) before
  // the model is installed, so that they and the model take its place as one unit (the
  // pre-training record); false with *error stops the save (nothing replaced).
  std::function<bool(const std::string& staging, std::string* error)> add_files;
};

// Writes the whole model to `directory`: into a staging directory beside it, which then
// takes its place in one step (util/staged_directory.h), so that a process killed at
// any moment leaves the old or the new model there. Creates missing parent folders.
// Returns false with *error on failure (nothing replaced).
bool SaveModel(const std::string& directory, const ActiveModel& model,
               const SaveModelOptions& options, std::string* error);
bool SaveModel(const std::string& directory, const ActiveModel& model, std::string* error);

// Replaces the learned state of a saved model (learned/: decoder, latents, states and
// the checkpoint) as one unit, for training checkpoints: written into
// "learned.aqs-tmp<pid>" and exchanged with learned/ in one step. A format-1 model is
// rewritten whole as format 2 (its training log and pre-training record kept).
bool SaveLearnedState(const std::string& directory, const ActiveModel& model, std::string* error);

// Reads and validates (ValidateModel) a model directory (format 1 or 2). Errors name the
// file (and line) that is missing or malformed, including an empty or malformed
// checkpoint.txt. The learned state is read as one unit: if a writer replaced it while
// it was read, it is read again.
bool LoadModel(const std::string& directory, ActiveModel* model, std::string* error);

}  // namespace aqs

#endif  // AQS_MODEL_MODEL_IO_H_
