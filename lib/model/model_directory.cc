#include "model/model_directory.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <set>

#include <glog/logging.h>

#include "util/atomic_file.h"
#include "util/line_reader.h"
#include "util/staged_directory.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

std::string WithoutTrailingSlashes(std::string path) {
  while (path.size() > 1 && path.back() == '/') path.pop_back();
  return path;
}

bool Exists(const std::string& path) {
  std::error_code code;
  return fs::exists(fs::symlink_status(path, code));
}

// Whether `name` is a file the model format puts in `folder` ("" is the model's top).
bool IsModelFileName(const std::string& folder, const std::string& name) {
  static const std::set<std::string> kTop = {
      "model.txt", "mesh.mesh", "mu.bin",  "fixed.txt",   "bones.txt",
      "neutral.obj", "embedding.txt", "poses.txt", "decoder.txt", "latents.bin", "prior.txt"};
  static const std::set<std::string> kTrain = {"checkpoint.txt", "log.csv"};
  static const std::set<std::string> kLearned = {"decoder.txt", "latents.bin", "prior.txt",
                                                 "checkpoint.txt"};
  // eval/error_budget.h: what pre-training reached; train/solver_checkpoint.h; the logs
  // (train/pretrain.h: log.csv the model's, run_log.csv that of a run in progress).
  static const std::set<std::string> kPretrain = {"surface_errors.bin", "surface_errors.txt",
                                                  "checkpoint.txt", "parameters_a.bin",
                                                  "parameters_b.bin", "log.csv", "run_log.csv",
                                                  "key.txt"};
  if (folder.empty()) return kTop.count(name) > 0;
  if (folder == "train") return kTrain.count(name) > 0;
  if (folder == "pretrain") return kPretrain.count(name) > 0;
  if (folder == "learned") return kLearned.count(name) > 0;
  // poses/, targets/, states/, learned/states/: NNNN.bin
  if (name.size() < 8 || name.compare(name.size() - 4, 4, ".bin") != 0) return false;
  for (size_t i = 0; i + 4 < name.size(); ++i) {
    if (name[i] < '0' || name[i] > '9') return false;
  }
  return true;
}

// Entries of the model folders `folders` ("" is the model's top) that are not part of
// the model format, as "folder/name".
std::vector<std::string> UnknownEntries(const std::string& dir,
                                        const std::vector<std::string>& folders) {
  static const std::set<std::string> kTopFolders = {"poses",   "targets", "states",
                                                    "learned", "train",   "pretrain"};
  std::vector<std::string> unknown;
  for (const std::string& folder : folders) {
    const std::string where = folder.empty() ? dir : dir + "/" + folder;
    std::error_code code;
    for (const fs::directory_entry& entry : fs::directory_iterator(where, code)) {
      const std::string name = entry.path().filename().string();
      const bool is_directory = entry.is_directory(code) && !entry.is_symlink(code);
      if (is_directory && ((folder.empty() && kTopFolders.count(name) > 0) ||
                           (folder == "learned" && name == "states"))) {
        continue;
      }
      if (!is_directory && entry.is_regular_file(code) && IsModelFileName(folder, name)) continue;
      unknown.push_back(folder.empty() ? name : folder + "/" + name);
    }
  }
  return unknown;
}

std::string ListSome(const std::vector<std::string>& names) {
  std::string list;
  for (size_t i = 0; i < names.size() && i < 3; ++i) list += (i ? ", " : "") + names[i];
  if (names.size() > 3) list += ", ... (" + std::to_string(names.size()) + " in all)";
  return list;
}

// Directories of ActiveQS before format 2 beside the model: "DIR.old<pid>" (the old
// model moved aside) and "DIR.tmp<pid>" (the new one being written).
bool CleanLegacySiblings(const std::string& target, std::vector<std::string>* actions,
                         std::string* error) {
  const fs::path path(target);
  const std::string parent = path.parent_path().empty() ? "." : path.parent_path().string();
  const std::string base = path.filename().string();
  std::vector<std::pair<std::string, long>> olds, tmps;
  std::error_code code;
  for (const fs::directory_entry& entry : fs::directory_iterator(parent, code)) {
    const std::string name = entry.path().filename().string();
    if (const long pid = StaleWriterPid(name, base, ".old"); pid >= 0) {
      olds.emplace_back(entry.path().string(), pid);
    } else if (const long pid = StaleWriterPid(name, base, ".tmp"); pid >= 0) {
      tmps.emplace_back(entry.path().string(), pid);
    }
  }
  if (!Exists(target)) {
    for (auto it = olds.begin(); it != olds.end(); ++it) {
      if (ModelFormatVersion(it->first) == 0) continue;
      if (::rename(it->first.c_str(), target.c_str()) != 0) {
        *error = "cannot move " + it->first + " back to " + target + " (" + std::strerror(errno) +
                 ")";
        return false;
      }
      actions->push_back("recovered " + target + " from " + it->first +
                         " (moved aside by an earlier ActiveQS version, process " +
                         std::to_string(it->second) + ", which stopped before replacing it)");
      olds.erase(it);
      break;
    }
  }
  for (const auto* list : {&olds, &tmps}) {
    for (const auto& [leftover, pid] : *list) {
      actions->push_back("kept " + leftover + ": probably left by an earlier ActiveQS version "
                         "(process " + std::to_string(pid) + "); remove it yourself if it is "
                         "not needed");
    }
  }
  return true;
}

// Temporary files "<name>.tmp<pid>" of util/atomic_file.h inside the model.
bool CleanTemporaryFiles(const std::string& dir, std::vector<std::string>* actions,
                         std::string* error) {
  for (const char* folder : {"", "train", "pretrain", "poses", "targets", "states", "learned",
                             "learned/states"}) {
    const std::string where = *folder ? dir + "/" + folder : dir;
    const std::string model_folder = folder;
    if (!RemoveStaleTemporaryFiles(
            where, [&](const std::string& name) { return IsModelFileName(model_folder, name); },
            actions, error)) {
      return false;
    }
  }
  return true;
}

}  // namespace

std::string ResolveModelPath(const std::string& dir) {
  const std::string path = WithoutTrailingSlashes(dir);
  std::error_code code;
  if (fs::is_symlink(fs::symlink_status(path, code))) {
    const fs::path resolved = fs::canonical(path, code);
    if (!code) return resolved.string();
  }
  return path;
}

int ModelFormatVersion(const std::string& dir) {
  std::error_code code;
  if (!fs::is_regular_file(dir + "/model.txt", code)) return 0;
  LineReader reader(dir + "/model.txt");
  if (!reader.ok()) return 0;
  std::vector<std::string> tokens;
  while (reader.NextTokens(&tokens)) {
    int version = 0;
    if (tokens.size() == 2 && tokens[0] == "format" && ParseInt(tokens[1], &version)) {
      return version > 0 ? version : 0;
    }
  }
  return 0;
}

bool CheckModelDestination(const std::string& path, bool overwrite, std::string* error) {
  std::error_code code;
  const fs::file_status status = fs::status(path, code);
  if (!fs::exists(status)) {
    if (!fs::exists(fs::symlink_status(path, code))) return true;  // missing
  } else if (fs::is_directory(status)) {
    if (fs::is_empty(path, code) && !code) return true;
    if (ModelFormatVersion(path) > 0) {
      const std::vector<std::string> unknown = UnknownEntries(
          path, {"", "train", "pretrain", "poses", "targets", "states", "learned",
                 "learned/states"});
      if (unknown.empty() || overwrite) return true;
      *error = "model " + path + " holds files that are not part of an ActiveQS model (" +
               ListSome(unknown) + "); replacing the model would delete them: move them out "
               "first";
      return false;
    }
  }
  if (overwrite) return true;
  *error = path +
           (fs::is_directory(status)
                ? " is a directory that is not an ActiveQS model (no model.txt with a 'format' "
                  "line)"
                : " exists and is not an ActiveQS model directory") +
           "; refusing to replace it";
  return false;
}

bool CheckLearnedStateDestination(const std::string& dir, std::string* error) {
  const std::vector<std::string> unknown = UnknownEntries(dir, {"learned", "learned/states"});
  if (unknown.empty()) return true;
  *error = "model " + dir + " holds files that are not part of an ActiveQS model (" +
           ListSome(unknown) + "); a checkpoint would delete them: move them out first";
  return false;
}

bool LockModelForWriting(const std::string& dir, std::ostream* log, PathLock* lock,
                         std::string* error) {
  const std::string target = ResolveModelPath(dir);
  if (!lock->Acquire(target, error, "model " + WithoutTrailingSlashes(dir))) return false;
  if (!lock->first()) return true;
  std::vector<std::string> actions;
  const bool ok = CleanModelLeftovers(target, &actions, error);
  for (const std::string& action : actions) {
    if (log != nullptr) {
      *log << "cleanup: " << action << "\n";
    } else {
      LOG(INFO) << "cleanup: " << action;
    }
  }
  if (!ok) {
    *error = "cleaning up after an earlier run: " + *error;
    lock->Release();
  }
  return ok;
}

bool CleanModelLeftovers(const std::string& dir, std::vector<std::string>* actions,
                         std::string* error) {
  const std::string target = WithoutTrailingSlashes(dir);
  if (!CleanLeftovers(target, "model.txt", actions, error) ||
      !CleanLegacySiblings(target, actions, error)) {
    return false;
  }
  if (ModelFormatVersion(target) == 0) return true;
  return CleanLeftovers(target + "/learned", "checkpoint.txt", actions, error) &&
         CleanTemporaryFiles(target, actions, error);
}

}  // namespace aqs
