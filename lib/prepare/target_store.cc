#include "prepare/target_store.h"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "model/model_directory.h"
#include "model/model_fingerprint.h"
#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/make_directory.h"
#include "util/matrix_io.h"
#include "util/number_format.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

std::string PosePath(const std::string& directory, int p, const char* extension) {
  char name[32];
  std::snprintf(name, sizeof(name), "/%04d.%s", p, extension);
  return directory + name;
}

std::string ReadWhole(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace

std::string VolumetricTargetKey(const VolumetricTargetOptions& options, const ActiveModel& model) {
  const QuasistaticSolverOptions& s = options.solver;
  std::ostringstream key;
  key << "model " << FingerprintText(ModelFingerprint(model)) << "\n"
      << "relative_stiffness " << FormatDouble(options.relative_stiffness) << "\n"
      << "continuation_steps " << options.continuation_steps << "\n"
      << "solver " << static_cast<int>(s.method) << " " << FormatDouble(s.relative_force_tolerance)
      << " " << s.max_iterations << " " << s.max_lbfgs_iterations << " "
      << s.negative_curvature_steps << " " << s.ensure_stable << " "
      << FormatDouble(s.newton_relative_force) << "\n";
  return key.str();
}

bool TargetStore::Open(const std::string& directory, const std::string& key, std::string* error) {
  directory_ = directory;
  std::error_code code;
  if (fs::exists(directory, code) && ReadWhole(directory + "/key.txt") != key) {
    for (const fs::directory_entry& entry : fs::directory_iterator(directory, code)) {
      fs::remove_all(entry.path(), code);
      if (code) {
        *error = entry.path().string() + ": cannot remove (" + code.message() + ")";
        return false;
      }
    }
  }
  if (!MakeDirectory(directory, error)) return false;
  if (ReadWhole(directory + "/key.txt") == key) return true;
  return WriteFileAtomically(directory + "/key.txt", key, error);
}

bool TargetStore::Load(int p, int num_elements, TrainingPose* pose, std::string* failure) const {
  const std::string text = PosePath(directory_, p, "txt");
  std::error_code code;
  if (directory_.empty() || !fs::exists(text, code)) return false;
  LineReader reader(text);
  double mean = -1.0, max = -1.0;
  std::string failed;
  std::vector<std::string> tokens;
  while (reader.NextTokens(&tokens, '\0')) {
    if (tokens.size() == 2 && tokens[0] == "mean") ParseDouble(tokens[1], &mean);
    if (tokens.size() == 2 && tokens[0] == "max") ParseDouble(tokens[1], &max);
    if (!tokens.empty() && tokens[0] == "failed") failed = reader.line().substr(7);
  }
  Eigen::MatrixXd target;
  std::string ignored;
  if (!reader.ok() || !(mean >= 0) || !(max >= 0) ||
      !ReadMatrixFile(PosePath(directory_, p, "bin"), 6, num_elements, &target, &ignored) ||
      !target.allFinite()) {
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
  if (!WriteMatrixFile(PosePath(directory_, p, "bin"), pose.target, error)) return false;
  std::string text = "mean " + FormatDouble(pose.embedding_mean_error) + "\nmax " +
                     FormatDouble(pose.embedding_max_error) + "\n";
  if (!failure.empty()) {
    std::string line = failure;
    for (char& c : line) c = c == '\n' || c == '\r' ? ' ' : c;
    text += "failed " + line + "\n";
  }
  return WriteFileAtomically(PosePath(directory_, p, "txt"), text, error);
}

std::string TargetStorePath(const std::string& model_directory) {
  return ResolveModelPath(model_directory) + ".aqs-targets";
}

bool RemoveTargetStore(const std::string& directory, std::string* error) {
  std::error_code code;
  fs::remove_all(directory, code);
  if (code) {
    *error = directory + ": cannot remove (" + code.message() + ")";
    return false;
  }
  return true;
}

}  // namespace aqs
