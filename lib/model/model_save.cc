#include "model/model_io.h"

// Writing models: the whole directory (SaveModel) or the learned unit (SaveLearnedState),
// each through a staging directory swapped in (util/staged_directory.h). Reading:
// model_load.cc.

#include <glog/logging.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <sstream>

#include "mesh/mesh_io.h"
#include "model/model_directory.h"
#include "model/model_files.h"
#include "model/model_fingerprint.h"
#include "util/atomic_file.h"
#include "util/input_file.h"
#include "util/make_directory.h"
#include "util/matrix_io.h"
#include "util/number_format.h"
#include "util/path_lock.h"
#include "util/staged_directory.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

bool WriteText(const std::string& path, const std::string& text, std::string* error) {
  return WriteFileAtomically(path, text, error);
}

std::string CheckpointText(const TrainingCheckpoint& checkpoint, uint64_t fingerprint) {
  std::string text =
      "# ActiveQS learned state: end-to-end training iterations done, loss after the last,\n"
      "# fingerprint of the model it belongs to (model/model_fingerprint.h)\n"
      "iterations " +
      std::to_string(checkpoint.iterations) + "\n";
  if (std::isfinite(checkpoint.loss)) {
    text += "loss ";
    AppendDouble(checkpoint.loss, &text);
    text += "\n";
  }
  if (!checkpoint.loss_weights.empty()) {
    text += "loss_weights " + checkpoint.loss_weights + "\n";
  }
  if (checkpoint.latent_refit_at >= 0) {
    text += "latent_refit_at " + std::to_string(checkpoint.latent_refit_at) + "\n";
  }
  text += "model " + FingerprintText(fingerprint) + "\n";
  return text;
}

// The learned unit's files into `dir` (learned/ or its staging directory). The fit
// prior is learned from the latents being written, so it always belongs to them.
bool WriteLearned(const std::string& dir, const ActiveModel& model, std::string* error) {
  if (model.decoder) {
    FitPrior prior;
    if (!LearnFitPrior(model, FitPriorOptions(), &prior, error)) {
      *error = "the learned model's fit prior: " + *error;
      return false;
    }
    if (!SaveDecoder(dir + "/decoder.txt", model.decoder->spec(),
                     model.decoder->field().description(), model.decoder_params, error) ||
        !WriteMatrixFile(dir + "/latents.bin", model.latents, error) ||
        !WriteFitPrior(dir + "/prior.txt", prior, internal::BoneNames(model), error)) {
      return false;
    }
  }
  if (!model.states.empty()) {
    if (!MakeDirectory(dir + "/states", error)) return false;
    for (int p = 0; p < model.num_poses(); ++p) {
      if (model.states[p].cols() == 0) continue;
      if (!WriteMatrixFile(internal::PoseFile(dir + "/states", p), model.states[p], error))
        return false;
    }
  }
  // Written last, though the unit is only seen whole: its identity file
  // (util/staged_directory.h).
  return WriteText(dir + "/checkpoint.txt",
                   CheckpointText(model.checkpoint, ModelFingerprint(model)), error);
}

bool HasLearnedState(const ActiveModel& model) { return model.decoder || !model.states.empty(); }

bool WriteAll(const std::string& dir, const ActiveModel& model, std::string* error) {
  std::ostringstream manifest;
  manifest << "# ActiveQS model (docs/model_format.md)\n"
           << "format " << internal::kModelFormatVersion << "\n"
           << "vertices " << model.mesh.num_vertices() << "\n"
           << "elements " << model.mesh.num_tets() << "\n"
           << "surface_vertices " << model.num_surface_vertices() << "\n"
           << "poses " << model.num_poses() << "\n"
           << "bones " << model.bones.size() << "\n"
           << "trained " << (model.decoder ? 1 : 0) << "\n";
  if (!model.target_key.empty()) manifest << "targets " << model.target_key << "\n";
  if (!WriteText(dir + "/model.txt", manifest.str(), error) ||
      !WriteMeditMesh(dir + "/mesh.mesh", model.mesh, error) ||
      !WriteMatrixFile(dir + "/mu.bin", model.mu.transpose(), error) ||
      !WriteObj(dir + "/neutral.obj", model.neutral, error)) {
    return false;
  }
  std::string fixed = "# vertex bone (-1: static at rest)\n";
  for (int v : model.static_vertices) fixed += std::to_string(v) + " -1\n";
  for (size_t b = 0; b < model.bones.size(); ++b) {
    for (int v : model.bones[b].vertices)
      fixed += std::to_string(v) + " " + std::to_string(b) + "\n";
  }
  std::string bones = "# bone <b> <name>; then <b> <pose> rotation (row-major 9) translation (3)\n";
  for (size_t b = 0; b < model.bones.size(); ++b) {
    bones += "bone " + std::to_string(b) + " " + model.bones[b].name + "\n";
    for (int p = 0; p < model.num_poses(); ++p) {
      const RigidTransform& t = model.bones[b].pose_transforms[p];
      bones += std::to_string(b) + " " + std::to_string(p);
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
          bones += ' ';
          AppendDouble(t.rotation(r, c), &bones);
        }
      }
      for (int c = 0; c < 3; ++c) {
        bones += ' ';
        AppendDouble(t.translation[c], &bones);
      }
      bones += '\n';
    }
  }
  std::string embedding =
      "# element w0 w1 w2 w3 ox oy oz outside_distance, one line per surface vertex\n";
  for (int i = 0; i < model.embedding.num_points(); ++i) {
    embedding += std::to_string(model.embedding.element[i]);
    for (int k = 0; k < 4; ++k) {
      embedding += ' ';
      AppendDouble(model.embedding.weights(k, i), &embedding);
    }
    for (int k = 0; k < 3; ++k) {
      embedding += ' ';
      AppendDouble(model.embedding.offsets(k, i), &embedding);
    }
    embedding += ' ';
    AppendDouble(model.embedding.outside_distance[i], &embedding);
    embedding += '\n';
  }
  std::string poses = "# index name embedding_mean_error embedding_max_error\n";
  for (int p = 0; p < model.num_poses(); ++p) {
    poses += std::to_string(p) + " " + model.poses[p].name + " ";
    AppendDouble(model.poses[p].embedding_mean_error, &poses);
    poses += ' ';
    AppendDouble(model.poses[p].embedding_max_error, &poses);
    poses += '\n';
  }
  if (!WriteText(dir + "/fixed.txt", fixed, error) ||
      !WriteText(dir + "/bones.txt", bones, error) ||
      !WriteText(dir + "/embedding.txt", embedding, error) ||
      !WriteText(dir + "/poses.txt", poses, error) || !MakeDirectory(dir + "/poses", error)) {
    return false;
  }
  bool any_target = false;
  for (const TrainingPose& pose : model.poses) any_target |= pose.target.cols() > 0;
  if (any_target && !MakeDirectory(dir + "/targets", error)) return false;
  for (int p = 0; p < model.num_poses(); ++p) {
    if (!WriteMatrixFile(internal::PoseFile(dir + "/poses", p), model.poses[p].surface, error))
      return false;
    if (model.poses[p].target.cols() > 0 &&
        !WriteMatrixFile(internal::PoseFile(dir + "/targets", p), model.poses[p].target, error)) {
      return false;
    }
  }
  if (!HasLearnedState(model)) return true;
  return MakeDirectory(dir + "/" + internal::kLearnedFolder, error) &&
         WriteLearned(dir + "/" + internal::kLearnedFolder, model, error);
}

// Holds the model's lock for a save, unless the caller does already.
bool LockForSave(const std::string& directory, PathLock* lock, std::string* error) {
  return LockModelForWriting(directory, nullptr, lock, error);
}

// Puts a filled staging directory at `target`; a failure to remove the replaced
// content is only logged (the next writer removes it).
bool Install(const std::string& staging, const std::string& target, std::string* error) {
  std::string warning;
  if (!InstallStagingDirectory(staging, target, &warning, error)) {
    std::string ignored;
    RemoveTemporaryTree(staging, &ignored);
    return false;
  }
  if (!warning.empty()) LOG(WARNING) << target << ": " << warning;
  return true;
}

}  // namespace

bool SaveModel(const std::string& directory, const ActiveModel& model, std::string* error) {
  return SaveModel(directory, model, SaveModelOptions(), error);
}

bool SaveModel(const std::string& directory, const ActiveModel& model,
               const SaveModelOptions& options, std::string* error) {
  if (!ValidateModel(model, directory, error)) return false;
  const std::string target = ResolveModelPath(directory);
  const fs::path parent = fs::path(target).parent_path();
  if (!parent.empty() && !MakeDirectory(parent.string(), error)) return false;
  PathLock lock;
  if (!LockForSave(target, &lock, error) ||
      !CheckModelDestination(target, options.overwrite, error)) {
    return false;
  }
  const std::string staging = StagingPathOf(target);
  if (!CreateStagingDirectory(staging, error)) return false;
  bool ok = WriteAll(staging, model, error);
  // (The record pretrain/key.txt last: it says the pre-training's record is whole. The
  // copies are flushed to the disk before the model is installed, as written files are.)
  for (const char* record : {"train/log.csv", "pretrain/surface_errors.bin",
                             "pretrain/surface_errors.txt", "pretrain/log.csv",
                             "pretrain/key.txt"}) {
    const std::string from = target + "/" + record;
    if (!ok || !options.keep_records || !MayExist(from)) continue;
    const std::string to = staging + "/" + record;
    std::error_code code;
    ok = MakeDirectory(fs::path(to).parent_path().string(), error);
    if (ok) fs::copy_file(from, to, code);
    if (ok && code) {
      *error = from + ": cannot copy into the new model (" + code.message() + ")";
      ok = false;
    }
    ok = ok && SyncFile(to, error);
  }
  if (ok && options.add_files) ok = options.add_files(staging, error);
  if (!ok) {
    std::string ignored;
    RemoveTemporaryTree(staging, &ignored);
    return false;
  }
  return Install(staging, target, error);
}

bool SaveLearnedState(const std::string& directory, const ActiveModel& model, std::string* error) {
  if (!ValidateModel(model, directory, error)) return false;
  const std::string target = ResolveModelPath(directory);
  PathLock lock;
  if (!LockForSave(target, &lock, error)) return false;
  const int version = ModelFormatVersion(target);
  if (version == 1) {
    SaveModelOptions upgrade;
    upgrade.keep_records = true;
    return SaveModel(target, model, upgrade, error);
  }
  if (version != internal::kModelFormatVersion) {
    *error = target + "/model.txt: expected 'format " +
             std::to_string(internal::kModelFormatVersion) + "' (save the whole model first)";
    return false;
  }
  if (!CheckLearnedStateDestination(target, error)) return false;
  const std::string learned = target + "/" + internal::kLearnedFolder;
  const std::string staging = StagingPathOf(learned);
  if (!CreateStagingDirectory(staging, error)) return false;
  if (!WriteLearned(staging, model, error)) {
    std::string ignored;
    RemoveTemporaryTree(staging, &ignored);
    return false;
  }
  return Install(staging, learned, error);
}

}  // namespace aqs
