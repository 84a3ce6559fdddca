#ifndef AQS_MODEL_MODEL_FINGERPRINT_H_
#define AQS_MODEL_MODEL_FINGERPRINT_H_

#include <cstdint>
#include <string>

#include "model/active_model.h"

namespace aqs {

// A 64-bit fingerprint of what aqs_prepare made of a model, which its learned state
// belongs to: the simulation mesh (rest positions and elements), mu, the fixed
// vertices and bones (vertices, names, per-pose transforms), the neutral surface's
// vertices, the embedding, and the training poses (names and surfaces). Not the
// volumetric targets nor anything learned. FNV-1a over the numbers' bytes, so it is
// the same for a model and the model saved and loaded again (the files keep every
// double exactly), and differs for another mesh, pose set, pose order or embedding.
uint64_t ModelFingerprint(const ActiveModel& model);

// A 64-bit fingerprint of a model's decoder architecture (latent size, activation,
// output scale, anchoring, linear skip, control nodes and their grid: origin, spacing,
// dimensions, kept nodes; elements, parameter count, hidden widths); 0 for a model
// without a decoder. Not its parameters.
uint64_t DecoderArchitectureFingerprint(const ActiveModel& model);

// A 64-bit fingerprint of what training made of a model, which results computed with
// it belong to: the decoder's architecture and parameters, the latents, the stored
// equilibria and the fit priors (as ModelFingerprint, the same after a save and load).
// Not the training checkpoint's counters.
uint64_t LearnedStateFingerprint(const ActiveModel& model);

// A hash of a surface's faces (triangles, polygons), as 16 hexadecimal digits: the
// neutral's faces, which ModelFingerprint leaves out (a model whose neutral.obj was
// triangulated again keeps its learned state; fits of point clouds and the attachment
// springs' weights read them).
std::string FacesFingerprint(const SurfaceMesh& surface);

// The fingerprint as 16 lowercase hexadecimal digits, and back (false if `text` is
// not 1 to 16 hexadecimal digits).
std::string FingerprintText(uint64_t fingerprint);
bool ParseFingerprint(const std::string& text, uint64_t* fingerprint);

}  // namespace aqs

#endif  // AQS_MODEL_MODEL_FINGERPRINT_H_
