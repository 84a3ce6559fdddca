#ifndef AQS_DIST_MODEL_SHARING_H_
#define AQS_DIST_MODEL_SHARING_H_

#include <string>

#include "dist/communicator.h"
#include "model/active_model.h"

namespace aqs {

// For a job that every rank of `comm` runs on the model directory `directory` (one
// path, read on every machine: a shared folder or a copy), after each rank tried to
// load it (`loaded`; *error says why not). Collective. Checks, on every rank, that
//   - every rank loaded it (else all fail with the lowest failing rank's message);
//   - every rank has rank 0's model: the same ModelFingerprint (mesh, fixed vertices,
//     bones, embedding, poses) and the same decoder architecture (latent size,
//     layers, activation, anchoring, control grid, parameter count), and the same
//     faces of the neutral surface (FacesFingerprint); else all fail with a message
//     naming the rank;
// then copies rank 0's learned numbers (decoder parameters, latents, fit prior, per-pose
// equilibria, none where rank 0 has none, checkpoint) to every rank, so that all ranks
// start from the state rank 0 read (another machine's copy of the directory may hold an
// older learned state: only its prepared part and decoder architecture are used).
// Returns false with *error on every rank if a check fails.
bool ShareModel(const Communicator& comm, const std::string& directory, bool loaded,
                ActiveModel* model, std::string* error);

}  // namespace aqs

#endif  // AQS_DIST_MODEL_SHARING_H_
