#ifndef AQS_DIST_MODEL_BROADCAST_H_
#define AQS_DIST_MODEL_BROADCAST_H_

#include <string>

#include "dist/communicator.h"
#include "model/active_model.h"

namespace aqs {

// Rank 0's model in memory (`*model` on rank 0; replaced on the others) on every rank of
// `comm`, for work that rank 0 shares before the model is saved (prepare's volumetric
// targets, pre-training's simulation of every pose). It travels as the model's own files:
// rank 0 saves it (SaveModel) into a temporary folder of its own, every file goes to the
// other ranks, and each writes them into a temporary folder of its own and loads them
// (LoadModel); the folders are removed. So every part a model directory holds arrives
// exactly (the files keep every double), and no folder is shared between machines. The
// folders are under the system's temporary directory (TMPDIR; std::filesystem's
// temp_directory_path), named "aqs-model-<pid>-<rank>"; rank 0's model is written there
// whole (with its volumetric targets, if it has them: leave them out when they are not
// needed, they are most of a large model's bytes). Collective; with one rank nothing is
// done. The other ranks' models are as LoadModel reads them (so they have fit priors
// where rank 0's has none: LoadModel learns them). Then every rank checks that it holds
// rank 0's ModelFingerprint and decoder (architecture, parameters) and latents. Returns
// false on every rank, with the lowest failing rank's message (Communicator::Agree),
// where a rank cannot write, read or load its folder.
bool BroadcastModel(const Communicator& comm, ActiveModel* model, std::string* error);

}  // namespace aqs

#endif  // AQS_DIST_MODEL_BROADCAST_H_
