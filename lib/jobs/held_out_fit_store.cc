#include "jobs/held_out_fit_store.h"

#include <algorithm>
#include <filesystem>
#include <string>

#include "model/model_fingerprint.h"
#include "util/atomic_file.h"
#include "util/fnv_hash.h"
#include "util/line_reader.h"
#include "util/matrix_io.h"
#include "util/text_split.h"

namespace aqs {
namespace {

constexpr int kScalars = 8;

// A fit's start as a number: the training pose's index, -1 for the mean latent, -2 for
// a failed fit; and back.
int StartIndex(const ActiveModel& model, const std::string& start) {
  if (start == kFailedFitStart) return -2;
  for (int p = 0; p < model.num_poses(); ++p) {
    if (model.poses[p].name == start) return p;
  }
  return -1;
}

std::string StartName(const ActiveModel& model, int index) {
  if (index == -2) return kFailedFitStart;
  return index >= 0 && index < model.num_poses() ? model.poses[index].name : kMeanLatentStart;
}

// The record at `path` (NNNN.txt): its pose, surface fingerprint and message ("" where
// absent). False if it cannot be read.
bool ReadRecord(const std::string& path, std::string* pose, std::string* fingerprint,
                std::string* message) {
  LineReader reader(path);
  std::vector<std::string> tokens;
  while (reader.NextTokens(&tokens, '\0')) {
    const std::string& line = reader.line();
    if (tokens[0] == "pose" && line.size() > 5) *pose = line.substr(5);
    if (tokens[0] == "surface" && tokens.size() == 2) *fingerprint = tokens[1];
    if (tokens[0] == "message" && line.size() > 8) *message = line.substr(8);
  }
  return reader.ok();
}

// An item's key: the pose's name and its surface's fingerprint.
std::string ItemKey(const std::string& pose, const std::string& fingerprint) {
  return pose + "\n" + fingerprint;
}

}  // namespace

std::string SurfaceFingerprint(const Eigen::Matrix3Xd& surface) {
  const uint64_t columns = static_cast<uint64_t>(surface.cols());
  uint64_t hash = Fnv1a(&columns, sizeof(columns), kFnvOffsetBasis);
  hash = Fnv1a(surface.data(), sizeof(double) * surface.size(), hash);
  return FingerprintText(hash);
}

int HeldOutFitBlockSize(const ActiveModel& model) {
  return model.latent_dim() + 12 * static_cast<int>(model.bones.size()) +
         3 * model.mesh.num_vertices() + 3 * model.num_surface_vertices() + kScalars;
}

void PackHeldOutFit(const ActiveModel& model, const LatentFitResult& fit, double seconds,
                    std::vector<double>* block) {
  if (fit.failed) {  // zeros in the block's place; the start index says it failed
    block->insert(block->end(), HeldOutFitBlockSize(model) - kScalars, 0.0);
    block->insert(block->end(), {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, seconds, -2.0});
    return;
  }
  block->insert(block->end(), fit.latent.data(), fit.latent.data() + fit.latent.size());
  for (const RigidTransform& b : fit.bones) {
    block->insert(block->end(), b.rotation.data(), b.rotation.data() + 9);
    block->insert(block->end(), b.translation.data(), b.translation.data() + 3);
  }
  block->insert(block->end(), fit.state.data(), fit.state.data() + fit.state.size());
  block->insert(block->end(), fit.surface.data(), fit.surface.data() + fit.surface.size());
  block->insert(block->end(), {fit.rms_error, fit.mean_error, fit.max_error,
                               double(fit.iterations), double(fit.used_points),
                               fit.converged ? 1.0 : 0.0, seconds,
                               double(StartIndex(model, fit.start))});
}

void UnpackHeldOutFit(const ActiveModel& model, const double* x, LatentFitResult* fit,
                      double* seconds) {
  const std::string message = fit->message;
  *fit = LatentFitResult();
  fit->message = message;
  const double* scalars = x + HeldOutFitBlockSize(model) - kScalars;
  *seconds = scalars[6];
  fit->start = StartName(model, static_cast<int>(scalars[7]));
  if (fit->start == kFailedFitStart) {
    fit->failed = true;
    return;
  }
  const int d = model.latent_dim();
  fit->latent = Eigen::Map<const Eigen::VectorXd>(x, d);
  x += d;
  fit->bones.assign(model.bones.size(), RigidTransform());
  for (RigidTransform& b : fit->bones) {
    b.rotation = Eigen::Map<const Eigen::Matrix3d>(x);
    b.translation = Eigen::Map<const Eigen::Vector3d>(x + 9);
    x += 12;
  }
  fit->state = Eigen::Map<const Eigen::Matrix3Xd>(x, 3, model.mesh.num_vertices());
  x += 3 * model.mesh.num_vertices();
  fit->surface = Eigen::Map<const Eigen::Matrix3Xd>(x, 3, model.num_surface_vertices());
  fit->rms_error = scalars[0];
  fit->mean_error = scalars[1];
  fit->max_error = scalars[2];
  fit->iterations = static_cast<int>(scalars[3]);
  fit->used_points = static_cast<int>(scalars[4]);
  fit->converged = scalars[5] != 0.0;
}

std::string HeldOutFitKey(const ActiveModel& model, const LatentFitOptions& options,
                          bool training_pose_starts) {
  return "model " + FingerprintText(ModelFingerprint(model)) + "\nlearned " +
         FingerprintText(LearnedStateFingerprint(model)) + "\ntraining_pose_starts " +
         std::to_string(training_pose_starts) + "\n" + options.KeyText();
}

bool HeldOutFitStore::Open(const std::string& directory, const std::string& key,
                           std::string* error) {
  items_.clear();
  next_item_ = 0;
  if (!store_.Open(directory, key, error)) return false;
  // The items kept, by pose and surface (a list with a pose added or removed finds them).
  std::error_code code;
  for (const std::filesystem::directory_entry& entry :
       std::filesystem::directory_iterator(directory, code)) {
    const std::string name = entry.path().filename().string();
    const size_t dot = name.size() > 4 ? name.size() - 4 : 0;
    // NNNN.txt, at most 9 digits (a stray file of more would overflow std::stoi).
    if (dot < 4 || dot > 9 || name.compare(dot, 4, ".txt") != 0 ||
        name.find_first_not_of("0123456789") != dot) {
      continue;
    }
    const int item = std::stoi(name.substr(0, dot));
    std::string pose, fingerprint, message;
    if (ReadRecord(entry.path().string(), &pose, &fingerprint, &message)) {
      items_[ItemKey(pose, fingerprint)] = item;
    }
    next_item_ = std::max(next_item_, item + 1);
  }
  return true;
}

bool HeldOutFitStore::Load(const ActiveModel& model, const std::string& name,
                           const Eigen::Matrix3Xd& surface, LatentFitResult* fit,
                           double* seconds) const {
  if (!store_.is_open()) return false;
  const std::string fingerprint = SurfaceFingerprint(surface);
  const auto found = items_.find(ItemKey(OneLine(name), fingerprint));
  if (found == items_.end()) return false;
  const int t = found->second;
  std::string pose, recorded, message;
  const int size = HeldOutFitBlockSize(model);
  Eigen::MatrixXd block;
  std::string ignored;
  if (!ReadRecord(store_.ItemPath(t, "txt"), &pose, &recorded, &message) ||
      pose != OneLine(name) ||
      recorded != fingerprint ||
      !ReadMatrixFile(store_.ItemPath(t, "bin"), size, 1, &block, &ignored) ||
      !block.allFinite()) {
    return false;
  }
  fit->message = message;
  UnpackHeldOutFit(model, block.data(), fit, seconds);
  return true;
}

bool HeldOutFitStore::Save(const ActiveModel& model, const std::string& name,
                           const Eigen::Matrix3Xd& surface, const LatentFitResult& fit,
                           double seconds, std::string* error) {
  // The pose's item if it has one (a fit kept that could not be read), else a new one.
  const std::string key = ItemKey(OneLine(name), SurfaceFingerprint(surface));
  const auto found = items_.find(key);
  const int t = found != items_.end() ? found->second : next_item_++;
  items_[key] = t;
  std::vector<double> block;
  PackHeldOutFit(model, fit, seconds, &block);
  const Eigen::Map<const Eigen::MatrixXd> column(block.data(),
                                                 static_cast<Eigen::Index>(block.size()), 1);
  // The record names the pose whose numbers the .bin holds: it goes before the .bin is
  // replaced (item t may hold this pose's earlier fit, or numbers a killed write left),
  // so that a failed or killed write never leaves a record over other numbers.
  std::error_code code;
  std::filesystem::remove(store_.ItemPath(t, "txt"), code);
  if (code) {
    *error = store_.ItemPath(t, "txt") + ": cannot remove (" + code.message() + ")";
    return false;
  }
  if (!WriteMatrixFile(store_.ItemPath(t, "bin"), column, error)) return false;
  std::string record = "pose " + OneLine(name) + "\nsurface " + SurfaceFingerprint(surface) + "\n";
  if (!fit.message.empty()) record += "message " + OneLine(fit.message) + "\n";
  return WriteFileAtomically(store_.ItemPath(t, "txt"), record, error);
}

}  // namespace aqs
