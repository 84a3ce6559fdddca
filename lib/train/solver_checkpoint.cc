#include "train/solver_checkpoint.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <utility>

#include <glog/logging.h>

#include "util/atomic_file.h"
#include "util/fault_injection.h"
#include "util/fnv_hash.h"
#include "util/line_reader.h"
#include "util/make_directory.h"
#include "util/matrix_io.h"
#include "util/number_format.h"

namespace aqs {
namespace {

constexpr const char* kSlots[2] = {"parameters_a.bin", "parameters_b.bin"};

std::string TextPath(const std::string& directory) { return directory + "/checkpoint.txt"; }

// The slot file the checkpoint in `directory` names ("" if none can be read).
std::string CurrentSlot(const std::string& directory) {
  std::error_code code;
  if (!std::filesystem::exists(TextPath(directory), code)) return "";
  LineReader reader(TextPath(directory));
  std::vector<std::string> tokens;
  while (reader.NextTokens(&tokens)) {
    if (tokens.size() == 3 && tokens[0] == "parameters") return tokens[1];
  }
  return "";
}

// The key's lines as checkpoint.txt holds them ("key NAME VALUE\n" each).
std::string KeyLines(const CheckpointKey& key) {
  std::string text;
  for (const auto& [name, value] : key) text += "key " + name + " " + value + "\n";
  return text;
}

// The kept folder's name of a checkpoint whose key lines (KeyLines) are `text`.
std::string KeptNameOfKeyLines(const std::string& text) {
  char name[17];
  std::snprintf(name, sizeof(name), "%016llx",
                static_cast<unsigned long long>(Fnv1a(text.data(), text.size(),
                                                      kFnvOffsetBasis)));
  return name;
}

// Copies `from` to `to` (replaced) and syncs it; a missing `from` is fine (nothing to
// copy). False with *error otherwise.
bool CopySynced(const std::string& from, const std::string& to, std::string* error) {
  std::error_code code;
  if (!std::filesystem::exists(from, code)) return true;
  std::filesystem::copy_file(from, to, std::filesystem::copy_options::overwrite_existing,
                             code);
  if (code) {
    *error = from + ": cannot copy to " + to + " (" + code.message() + ")";
    return false;
  }
  return SyncFile(to, error);
}

}  // namespace

bool SameLoss(double loss, double recorded) {
  return std::isfinite(loss) && std::isfinite(recorded) &&
         std::abs(loss - recorded) <= 1e-6 * std::max(std::abs(loss), std::abs(recorded));
}

bool ReadSolverCheckpoint(const std::string& directory, const CheckpointKey& key,
                          int num_parameters, SolverCheckpoint* checkpoint,
                          std::string* why_not) {
  why_not->clear();
  const std::string path = TextPath(directory);
  std::error_code code;
  if (!std::filesystem::exists(path, code)) return false;
  LineReader reader(path);
  std::map<std::string, std::string> values, keys;
  std::string slot;
  long long count = -1;
  while (reader.NextLine()) {
    const std::string& line = reader.line();
    if (line.empty() || line[0] == '#') continue;
    const size_t space = line.find(' ');
    const std::string name = line.substr(0, space);
    const std::string value = space == std::string::npos ? "" : line.substr(space + 1);
    if (name == "key") {
      const size_t split = value.find(' ');
      const std::string key_name = value.substr(0, split);
      if (keys.count(key_name) > 0) {
        *why_not = reader.Where("key '" + key_name + "' given twice");
        return false;
      }
      keys[key_name] = split == std::string::npos ? "" : value.substr(split + 1);
      continue;
    }
    if (values.count(name) > 0) {
      *why_not = reader.Where("'" + name + "' given twice");
      return false;
    }
    values[name] = value;
    if (name == "parameters") {
      std::istringstream in(value);
      std::string count_text, rest;
      if (!(in >> slot >> count_text) || (in >> rest) || !ParseInt64(count_text, &count) ||
          (slot != kSlots[0] && slot != kSlots[1])) {
        *why_not = reader.Where("expected 'parameters " + std::string(kSlots[0]) + "|" +
                                kSlots[1] + " <count>'");
        return false;
      }
    }
  }
  if (!reader.ok()) {
    *why_not = reader.error();
    return false;
  }
  for (const char* name : {"iterations", "seconds", "loss", "parameters"}) {
    if (values.count(name) == 0) {
      *why_not = path + ": no '" + name + "' line";
      return false;
    }
  }
  for (const auto& [name, value] : key) {
    const auto saved = keys.find(name);
    if (saved == keys.end() || saved->second != value) {
      *why_not = "'" + name + "' differs (" +
                 (saved == keys.end() ? std::string("none") : saved->second) + "; now " +
                 value + ")";
      return false;
    }
  }
  if (keys.size() != key.size()) {
    *why_not = path + ": it has other key entries than this run's";
    return false;
  }
  SolverCheckpoint read;
  read.key = key;
  if (!ParseInt(values["iterations"], &read.iterations) || read.iterations < 0 ||
      !ParseDouble(values["seconds"], &read.seconds) || !(read.seconds >= 0) ||
      !ParseDouble(values["loss"], &read.loss) || !std::isfinite(read.loss)) {
    *why_not = path + ": 'iterations', 'seconds' or 'loss' is not a number >= 0";
    return false;
  }
  if (count != num_parameters) {
    *why_not = path + ": it holds " + std::to_string(count) + " parameters, this run has " +
               std::to_string(num_parameters);
    return false;
  }
  Eigen::MatrixXd parameters;
  if (!ReadMatrixFile(directory + "/" + slot, num_parameters, 1, &parameters, why_not)) {
    return false;
  }
  if (!parameters.allFinite()) {
    *why_not = directory + "/" + slot + ": a parameter is not finite";
    return false;
  }
  read.parameters = parameters.col(0);
  *checkpoint = std::move(read);
  return true;
}

std::string KeptCheckpointName(const CheckpointKey& key) {
  return KeptNameOfKeyLines(KeyLines(key));
}

bool MoveSolverCheckpointAside(const std::string& directory, const std::string& kept_root,
                               const std::vector<std::string>& also, bool* moved,
                               std::string* error) {
  namespace fs = std::filesystem;
  *moved = false;
  std::error_code code;
  const std::string text = TextPath(directory);
  if (!fs::exists(text, code)) return true;
  // The key lines as written (a damaged file: whatever key lines it has).
  std::string key_lines;
  LineReader reader(text);
  while (reader.NextLine()) {
    if (reader.line().rfind("key ", 0) == 0) key_lines += reader.line() + "\n";
  }
  const std::string kept = kept_root + "/" + KeptNameOfKeyLines(key_lines);
  const std::string staging = kept + ".tmp";
  if (!MakeDirectory(kept_root, error) || !RemoveDirectory(staging, error) ||
      !MakeDirectory(staging, error)) {
    return false;
  }
  std::vector<std::string> names = {"checkpoint.txt"};
  const std::string slot = CurrentSlot(directory);
  if (!slot.empty()) names.push_back(slot);
  names.insert(names.end(), also.begin(), also.end());
  for (const std::string& name : names) {
    if (!CopySynced(directory + "/" + name, staging + "/" + name, error)) return false;
  }
  FaultPoint("checkpoint_aside:copied");
  if (!RemoveDirectory(kept, error)) return false;
  FaultPoint("checkpoint_aside:old_removed");
  fs::rename(staging, kept, code);
  if (code) {
    *error = staging + ": cannot rename to " + kept + " (" + code.message() + ")";
    return false;
  }
  FaultPoint("checkpoint_aside:renamed");
  if (!fs::remove(text, code) && code) {
    *error = text + ": cannot remove the checkpoint of an earlier run (" + code.message() + ")";
    return false;
  }
  *moved = true;
  // At most kMaxKeptCheckpoints: the oldest go.
  std::vector<std::pair<fs::file_time_type, std::string>> all;
  for (const fs::directory_entry& entry : fs::directory_iterator(kept_root, code)) {
    const std::string path = entry.path().string();
    if (!entry.is_directory(code) || entry.path().extension() == ".tmp") continue;
    all.emplace_back(fs::last_write_time(TextPath(path), code), path);
  }
  std::sort(all.begin(), all.end());
  for (size_t k = 0; k + kMaxKeptCheckpoints < all.size(); ++k) {
    std::string ignored;
    RemoveDirectory(all[k].second, &ignored);
  }
  return true;
}

bool RemoveKeptCheckpoint(const std::string& kept_root, const CheckpointKey& key,
                          bool* removed, std::string* error) {
  std::error_code code;
  const std::string kept = kept_root + "/" + KeptCheckpointName(key);
  *removed = std::filesystem::exists(kept, code) || std::filesystem::exists(kept + ".tmp", code);
  return RemoveDirectory(kept, error) && RemoveDirectory(kept + ".tmp", error);
}

bool RestoreKeptCheckpoint(const std::string& directory, const std::string& kept_root,
                           const CheckpointKey& key, const std::vector<std::string>& also,
                           bool* restored, std::string* error) {
  namespace fs = std::filesystem;
  *restored = false;
  std::error_code code;
  CHECK(!fs::exists(TextPath(directory), code));
  const std::string kept = kept_root + "/" + KeptCheckpointName(key);
  if (!fs::exists(TextPath(kept), code)) return true;
  if (!MakeDirectory(directory, error)) return false;
  std::vector<std::string> names = also;
  const std::string slot = CurrentSlot(kept);
  if (!slot.empty()) names.push_back(slot);
  for (const std::string& name : names) {
    if (!CopySynced(kept + "/" + name, directory + "/" + name, error)) return false;
  }
  if (!WriteFileAtomically(TextPath(directory), ReadWholeFile(TextPath(kept)), error)) {
    return false;
  }
  std::string ignored;  // restored: a kept copy left behind is replaced by the next move
  RemoveDirectory(kept, &ignored);
  *restored = true;
  return true;
}

bool RemoveSolverCheckpoint(const std::string& directory, std::string* error) {
  const std::string path = TextPath(directory);
  std::error_code code;
  if (std::filesystem::remove(path, code) || !code) return true;
  *error = path + ": cannot remove the checkpoint of an earlier run (" + code.message() + ")";
  return false;
}

bool WriteSolverCheckpoint(const std::string& directory, const SolverCheckpoint& checkpoint,
                           std::string* error) {
  if (!MakeDirectory(directory, error)) return false;
  const std::string slot = CurrentSlot(directory) == kSlots[0] ? kSlots[1] : kSlots[0];
  if (!WriteMatrixFile(directory + "/" + slot, checkpoint.parameters, error)) return false;
  FaultPoint("solver_checkpoint:parameters_written");
  std::ostringstream text;
  text << "# ActiveQS solver checkpoint (train/solver_checkpoint.h)\n";
  text << KeyLines(checkpoint.key);
  text << "iterations " << checkpoint.iterations << "\n"
       << "seconds " << FormatDouble(checkpoint.seconds) << "\n"
       << "loss " << FormatDouble(checkpoint.loss) << "\n"
       << "parameters " << slot << " " << checkpoint.parameters.size() << "\n";
  return WriteFileAtomically(TextPath(directory), text.str(), error);
}

SolverCheckpointWriter::SolverCheckpointWriter(std::string directory,
                                               const SolverCheckpoint& start,
                                               double every_seconds, const double* parameters,
                                               int num_parameters)
    : directory_(std::move(directory)),
      every_seconds_(every_seconds),
      parameters_(parameters),
      num_parameters_(num_parameters),
      start_iterations_(start.iterations),
      start_seconds_(start.seconds) {
  checkpoint_.key = start.key;
}

ceres::CallbackReturnType SolverCheckpointWriter::operator()(
    const ceres::IterationSummary& summary) {
  if (summary.iteration == 0 || since_write_.Seconds() < every_seconds_) {
    return ceres::SOLVER_CONTINUE;
  }
  return Write(start_iterations_ + summary.iteration, summary.cost) ? ceres::SOLVER_CONTINUE
                                                                    : ceres::SOLVER_ABORT;
}

bool SolverCheckpointWriter::Write(int iterations, double loss) {
  checkpoint_.iterations = iterations;
  checkpoint_.seconds = start_seconds_ + run_timer_.Seconds();
  checkpoint_.loss = loss;
  checkpoint_.parameters = Eigen::Map<const Eigen::VectorXd>(parameters_, num_parameters_);
  if (!WriteSolverCheckpoint(directory_, checkpoint_, &error_)) return false;
  since_write_.Reset();
  ++checkpoints_;
  return true;
}

}  // namespace aqs
