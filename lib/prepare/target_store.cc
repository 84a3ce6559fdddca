#include "prepare/target_store.h"

#include <cstdint>
#include <filesystem>
#include <sstream>

#include "io/actuation_io.h"
#include "model/model_directory.h"
#include "model/model_fingerprint.h"
#include "util/atomic_file.h"
#include "util/fnv_hash.h"
#include "util/line_reader.h"
#include "util/matrix_io.h"
#include "util/number_format.h"
#include "util/text_split.h"

namespace aqs {

std::string VolumetricTargetKey(const VolumetricTargetOptions& options, const ActiveModel& model) {
  std::ostringstream key;
  key << "model " << FingerprintText(ModelFingerprint(model)) << "\n"
      << "relative_stiffness " << FormatDouble(options.relative_stiffness) << "\n"
      << "continuation_steps " << options.continuation_steps << "\n"
      << "solver " << options.solver.KeyText() << "\n";
  // Models prepared before the option was made had mirror targets and no such line.
  if (options.inverted_targets != InvertedTargets::kMirror) {
    key << "inverted_targets " << InvertedTargetsName(options.inverted_targets) << "\n";
  }
  return key.str();
}

std::string TargetStoreKey(const VolumetricTargetOptions& options, const ActiveModel& model) {
  return VolumetricTargetKey(options, model) + "neutral_faces " + FacesFingerprint(model.neutral) +
         "\n";
}

std::string VolumetricTargetFingerprint(const VolumetricTargetOptions& options,
                                        const ActiveModel& model) {
  const std::string key = VolumetricTargetKey(options, model);
  return FingerprintText(Fnv1a(key.data(), key.size(), kFnvOffsetBasis));
}

bool TargetStore::Open(const std::string& directory, const std::string& key, std::string* error) {
  return store_.Open(directory, key, error);
}

bool TargetStore::Load(int p, int num_elements, TrainingPose* pose, std::string* failure) const {
  if (!store_.is_open()) return false;
  const std::string text = store_.ItemPath(p, "txt");
  std::error_code code;
  if (!std::filesystem::exists(text, code)) return false;
  LineReader reader(text);
  double mean = -1.0, max = -1.0;
  std::string failed;
  bool damaged = false;
  std::vector<std::string> tokens;
  while (reader.NextTokens(&tokens, '\0')) {
    if (tokens.size() == 2 && tokens[0] == "mean") ParseDouble(tokens[1], &mean);
    if (tokens.size() == 2 && tokens[0] == "max") ParseDouble(tokens[1], &max);
    if (!tokens.empty() && tokens[0] == "failed") {
      // "failed <message>" (Save writes a message): the text after the word.
      const std::string& line = reader.line();
      const size_t message = line.find("failed") + 7;
      failed = message < line.size() ? line.substr(message) : "";
      damaged = damaged || failed.empty();
    }
  }
  Eigen::MatrixXd target;
  std::string ignored;
  if (!reader.ok() || damaged || !(mean >= 0) || !(max >= 0) ||
      !ReadMatrixFile(store_.ItemPath(p, "bin"), 6, num_elements, &target, &ignored) ||
      !target.allFinite() || !CheckStoredTargets(store_.ItemPath(p, "bin"), target, &ignored)) {
    return false;
  }
  pose->target = target;
  pose->embedding_mean_error = mean;
  pose->embedding_max_error = max;
  *failure = failed;
  return true;
}

bool TargetStore::Save(int p, const TrainingPose& pose, const std::string& failure,
                       std::string* error) const {
  if (!WriteMatrixFile(store_.ItemPath(p, "bin"), pose.target, error)) return false;
  std::string text = "mean " + FormatDouble(pose.embedding_mean_error) + "\nmax " +
                     FormatDouble(pose.embedding_max_error) + "\n";
  if (!failure.empty()) text += "failed " + OneLine(failure) + "\n";
  return WriteFileAtomically(store_.ItemPath(p, "txt"), text, error);
}

std::string TargetStorePath(const std::string& model_directory) {
  return ResolveModelPath(model_directory) + ".aqs-targets";
}

}  // namespace aqs
