#ifndef AQS_MODEL_MODEL_FILES_H_
#define AQS_MODEL_MODEL_FILES_H_

// Internal to lib/model: what the model's writer (model_save.cc) and reader
// (model_load.cc) share about its directory's files (docs/model_format.md).

#include <string>
#include <vector>

#include "model/active_model.h"

namespace aqs {
namespace internal {

// The directory format written (model.txt's "format"); format 1 is still read.
inline constexpr int kModelFormatVersion = 2;

// The learned unit's folder in a format-2 model (decoder, latents, prior, states,
// checkpoint), replaced as a whole by every checkpoint.
inline constexpr char kLearnedFolder[] = "learned";

// Pose p's matrix file in `folder` (poses/, targets/ or states/): "<folder>/%04d.bin".
std::string PoseFile(const std::string& folder, int p);

// The model's bone names in its order (prior.txt and latent files name bones).
std::vector<std::string> BoneNames(const ActiveModel& model);

}  // namespace internal
}  // namespace aqs

#endif  // AQS_MODEL_MODEL_FILES_H_
