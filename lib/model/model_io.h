#ifndef AQS_MODEL_MODEL_IO_H_
#define AQS_MODEL_MODEL_IO_H_

#include <string>

#include "model/active_model.h"

namespace aqs {

// A model is a directory (docs/model_format.md):
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
//   decoder.txt       the decoder (learn/decoder.h), once pre-trained
//   latents.bin       latent_dim x num_poses, with the decoder
//   states/NNNN.bin   last equilibrium per pose (3 x num_vertices), where known
//
// Binary files use util/matrix_io.h. NNNN is the zero-padded pose index.

// Writes the whole model to `directory`: first into a sibling temporary directory,
// which then replaces `directory` (an existing model there is moved aside and removed
// only after the new one is in place). Returns false with *error on failure.
bool SaveModel(const std::string& directory, const ActiveModel& model, std::string* error);

// Rewrites only the learned part of a saved model in place (decoder.txt, latents.bin,
// states/): each file atomically, for training checkpoints.
bool SaveLearnedState(const std::string& directory, const ActiveModel& model, std::string* error);

// Reads and validates (ValidateModel) a model directory. Errors name the file (and
// line) that is missing or malformed.
bool LoadModel(const std::string& directory, ActiveModel* model, std::string* error);

}  // namespace aqs

#endif  // AQS_MODEL_MODEL_IO_H_
