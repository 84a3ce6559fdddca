#include "jobs/learning_jobs.h"

#include <filesystem>
#include <sstream>

#include <glog/logging.h>

#include "dist/communicator.h"
#include "dist/model_broadcast.h"
#include "dist/model_sharing.h"
#include "geometry/embedding.h"
#include "jobs/pretrain_record.h"
#include "jobs/shared_pose_work.h"
#include "model/model_directory.h"
#include "model/model_io.h"
#include "train/progress.h"
#include "util/atomic_file.h"
#include "util/make_directory.h"
#include "util/memory_limit.h"
#include "util/number_format.h"
#include "util/text_split.h"
#include "util/wall_timer.h"

namespace aqs {

std::string KeptPretrainCheckpointsPath(const std::string& model_directory) {
  return ResolveModelPath(model_directory) + ".aqs-pretrain-kept";
}
namespace {

// Takes the model's writers' lock (cleaning up after killed writers) and loads it. A
// model whose folder does not exist fails with LoadModel's message.
bool LockAndLoad(const std::string& model_directory, std::ostream& log, PathLock* lock,
                 ActiveModel* model, std::string* error) {
  std::string path = model_directory;
  while (path.size() > 1 && path.back() == '/') path.pop_back();
  std::error_code code;
  const std::filesystem::path parent =
      std::filesystem::absolute(path, code).lexically_normal().parent_path();
  if (!std::filesystem::is_directory(parent, code)) {
    LoadModel(model_directory, model, error);
    return false;
  }
  return LockModelForWriting(model_directory, &log, lock, error) &&
         LoadModel(model_directory, model, error);
}

// Whether the job's saves may replace what they replace (checked before the work): the
// whole model, or (training a format-2 model) its learned state.
bool CheckReplaceable(const std::string& model_directory, bool whole, std::string* error) {
  const std::string path = ResolveModelPath(model_directory);
  if (whole || ModelFormatVersion(path) == 1) return CheckModelDestination(path, false, error);
  return CheckLearnedStateDestination(path, error);
}

// The model's decoder against what the caller expects; false with *error naming both.
bool CheckExpectedDecoder(const std::string& model_directory, const ActiveModel& model,
                          const ExpectedDecoder& expected, std::string* error) {
  if (!model.decoder) return true;  // TrainEndToEnd says the model is not pre-trained
  const DecoderSpec& spec = model.decoder->spec();
  std::string mismatch;
  if (expected.latent_dim > 0 && expected.latent_dim != spec.latent_dim) {
    mismatch = "latent_dim=" + std::to_string(expected.latent_dim) + " was asked for, but the " +
               "model's decoder has latent_dim=" + std::to_string(spec.latent_dim);
  } else if (!expected.hidden_dims.empty() && expected.hidden_dims != spec.hidden_dims) {
    mismatch = "hidden_dims=" + JoinInts(expected.hidden_dims, "none") +
               " was asked for, but the model's decoder has hidden_dims=" +
               JoinInts(spec.hidden_dims, "none");
  } else if (!expected.activation.empty() && expected.activation != ActivationName(spec.activation)) {
    mismatch = "activation=" + expected.activation + " was asked for, but the model's decoder "
               "has activation=" + ActivationName(spec.activation);
  }
  if (mismatch.empty()) return true;
  *error = mismatch + " (model " + model_directory + "): the architecture is "
           "set by pre-training, which training continues; pre-train again to change it";
  return false;
}

// How far PretrainHere got.
enum class PretrainResult { kFailed, kKept, kPretrained };

// RunPretrainJob up to the pre-trained decoder: checks, the lock, the model, the record
// of an earlier pre-training (kept?) and the pre-training itself; *record is the record
// this pre-training writes at the end.
PretrainResult PretrainHere(const std::string& model_directory, const PretrainOptions& options,
                            const PoseSimulationOptions* simulation, std::ostream& log,
                            bool keep_pretrained, PathLock* lock, ActiveModel* model,
                            PretrainOptions* run, std::string* record, std::string* error) {
  if (!options.Validate(error)) return PretrainResult::kFailed;
  if (simulation != nullptr) {
    std::string simulation_error;
    if (!simulation->Validate(&simulation_error)) {
      *error = "simulation." + simulation_error;
      return PretrainResult::kFailed;
    }
  }
  if (!LockAndLoad(model_directory, log, lock, model, error) ||
      !CheckReplaceable(model_directory, true, error)) {
    return PretrainResult::kFailed;
  }
  // Sizes this model cannot take are refused first, before a kept decoder is compared
  // with these flags (they would otherwise be reported as flags that discard training).
  {
    double bytes = 0.0;
    std::string details;
    if (!PretrainMemoryBytes(options, *model, &bytes, &details, error) ||
        !CheckMemoryEstimate(bytes, options.max_memory_bytes, "pre-training", details, error)) {
      return PretrainResult::kFailed;
    }
  }
  *run = options;
  run->checkpoint_directory = ResolveModelPath(model_directory) + "/pretrain";
  run->kept_checkpoints_directory = KeptPretrainCheckpointsPath(model_directory);
  const std::string record_path = run->checkpoint_directory + "/" + kPretrainRecordName;
  *record = PretrainRecord(*run, *model, simulation != nullptr);
  if (keep_pretrained && model->decoder) {
    const std::string kept = ReadWholeFile(record_path);
    int stalled_restarts = -1;
    const PretrainRecordMatch match =
        MatchPretrainRecord(kept, *record, run->max_restarts, &stalled_restarts);
    const int trained = model->checkpoint.iterations;
    if (match == PretrainRecordMatch::kSame ||
        (match == PretrainRecordMatch::kCouldGoFurther && trained > 0)) {
      log << "pretrain: the model's decoder was pre-trained with these flags (" << record_path
          << "): kept, with " << trained << " training iterations since\n";
      if (match == PretrainRecordMatch::kCouldGoFurther) {
        log << "pretrain: note: it stalled before its budget with " << stalled_restarts
            << " L-BFGS restarts allowed; --train_restarts=" << run->max_restarts
            << " could take it further, but not without discarding the training since "
               "(--restart pre-trains anew)\n";
      }
      return PretrainResult::kKept;
    }
    if (match == PretrainRecordMatch::kCouldGoFurther) {
      log << "pretrain: the model's decoder stalled before its budget with " << stalled_restarts
          << " L-BFGS restarts allowed (" << record_path << "): pre-trained anew with "
          << "--train_restarts=" << run->max_restarts << ", which may take it further\n";
    } else if (trained > 0) {
      *error = "the model's decoder was pre-trained " +
               std::string(kept.empty() ? "without a record of how (" : "with other flags (") +
               record_path + ") and trained " + std::to_string(model->checkpoint.iterations) +
               " iterations since, which pre-training anew would discard: --restart "
               "pre-trains anew";
      return PretrainResult::kFailed;
    }
  }
  if (!keep_pretrained && model->decoder) {
    log << "pretrain: --restart: the model's decoder and latents (" << model->checkpoint.iterations
        << " training iterations) are replaced by a new pre-training\n";
  }
  PretrainReport report;
  if (!Pretrain(*run, model, &report, log, error)) return PretrainResult::kFailed;
  if (report.stalled_without_restarts) *record += PretrainStallLine(run->max_restarts);
  return PretrainResult::kPretrained;
}

// Every pose simulated (shared among the ranks of `comm`, or in this process if null),
// on rank 0: stage (b) of the error budget into *surface_errors and the equilibria into
// model->states, logged.
bool SimulatePretrainedPoses(const Communicator* comm, const PoseSimulationOptions& simulation,
                             ActiveModel* model, PretrainSurfaceErrors* surface_errors,
                             std::ostream& log, std::string* error) {
  // Stage (b) of the error budget: what the decoder reproduces of the targets, as
  // surfaces. Simulated from rest, as training's first evaluation would.
  WallTimer timer;
  std::vector<SimulatedPose> simulated;
  if (comm != nullptr) {
    // The other ranks take the model without its targets (most of its bytes; unused).
    std::vector<ActuationMatrix> targets(model->num_poses());
    for (int p = 0; p < model->num_poses(); ++p) targets[p].swap(model->poses[p].target);
    const bool shared = BroadcastModel(*comm, model, error);
    for (int p = 0; p < model->num_poses(); ++p) targets[p].swap(model->poses[p].target);
    if (!shared) return false;
    simulated = SimulateTrainingPosesOnRanks(*comm, *model, simulation);
  } else {
    simulated = SimulateTrainingPosesOnRanks(LocalCommunicator(), *model, simulation);
  }
  surface_errors->distances.resize(model->num_surface_vertices(), model->num_poses());
  model->states.assign(model->num_poses(), Eigen::Matrix3Xd());
  for (int p = 0; p < model->num_poses(); ++p) {
    surface_errors->distances.col(p) =
        VertexDistances(simulated[p].surface, model->poses[p].surface);
    surface_errors->converged.push_back(simulated[p].converged ? 1 : 0);
    if (simulated[p].converged) {
      model->states[p] = simulated[p].state;
    } else {
      log << "  pose '" << model->poses[p].name
          << "': the pre-trained actuation's equilibrium did not converge: "
          << simulated[p].message << "\n";
    }
  }
  log << "pretrain: the pre-trained poses simulated in " << FormatDuration(timer.Seconds())
      << (comm != nullptr ? " (shared among " + std::to_string(comm->size()) + " ranks)"
                          : std::string())
      << "; surface error over all surface vertices (model units):\n"
      << TrainingBudgetTable(*model, surface_errors, {});
  return true;
}

// On a rank other than 0 of a distributed pre-training: waits for rank 0's pre-trained
// model, if it simulates the poses, and simulates its share of them.
bool ServePretrain(const Communicator& comm, const PoseSimulationOptions* simulation,
                   std::string* error) {
  int simulate = 0;
  comm.Broadcast(&simulate, 1, 0);
  if (!simulate) return true;
  CHECK(simulation != nullptr) << "rank 0 simulates the pre-trained poses, this rank was not "
                                  "given the options";
  ActiveModel model;
  if (!BroadcastModel(comm, &model, error)) return false;
  SimulateTrainingPosesOnRanks(comm, model, *simulation);
  return true;
}

}  // namespace

bool RunPretrainJob(const std::string& model_directory, const PretrainOptions& options,
                    const PoseSimulationOptions* simulation, std::ostream& log,
                    std::string* error, bool keep_pretrained, const Communicator* communicator) {
  const Communicator* comm =
      communicator != nullptr && communicator->size() > 1 ? communicator : nullptr;
  if (comm != nullptr && !comm->is_root()) return ServePretrain(*comm, simulation, error);
  PathLock lock;
  ActiveModel model;
  PretrainOptions run;
  std::string record;
  const PretrainResult result = PretrainHere(model_directory, options, simulation, log,
                                             keep_pretrained, &lock, &model, &run, &record, error);
  if (comm != nullptr) {
    int simulate = result == PretrainResult::kPretrained && simulation != nullptr ? 1 : 0;
    comm->Broadcast(&simulate, 1, 0);
  }
  if (result != PretrainResult::kPretrained) return result == PretrainResult::kKept;
  PretrainSurfaceErrors surface_errors;
  if (simulation != nullptr &&
      !SimulatePretrainedPoses(comm, *simulation, &model, &surface_errors, log, error)) {
    return false;
  }
  // The CSV log of pre-training, its surface errors and its record go into the new model
  // (which replaces the folder and, with it, the checkpoint) before it is installed: the
  // model and its record take the folder's place as one unit. (Written after it, a kill
  // or a full disk in between left a pre-trained model without its record, which the
  // next run pre-trained again from iteration 0.)
  const std::string pretrain_log =
      ReadWholeFile(run.checkpoint_directory + "/" + kPretrainRunLogName);
  SaveModelOptions save;
  save.add_files = [&](const std::string& staging, std::string* file_error) {
    const std::string folder = staging + "/pretrain";
    if (!MakeDirectory(folder, file_error)) return false;
    if (!pretrain_log.empty() &&
        !WriteFileAtomically(folder + "/" + kPretrainLogName, pretrain_log, file_error)) {
      return false;
    }
    if (simulation != nullptr &&
        !WritePretrainSurfaceErrors(staging, model, surface_errors, file_error)) {
      return false;
    }
    // Last: its presence says the pre-training (and its record) is whole.
    return WriteFileAtomically(folder + "/" + kPretrainRecordName, record, file_error);
  };
  if (!SaveModel(model_directory, model, save, error)) return false;
  log << "wrote model " << model_directory << "\n";
  return true;
}

bool RunTrainJob(const std::string& model_directory, const TrainOptions& options, bool restart,
                 std::ostream& log, std::string* error, const ExpectedDecoder& expected) {
  // The same options on every rank: each refuses them alike, before any collective.
  if (!options.Validate(error)) return false;
  const Communicator* communicator = options.communicator;
  const bool distributed = communicator != nullptr && communicator->size() > 1;
  const bool root = !distributed || communicator->is_root();
  PathLock lock;
  ActiveModel model;
  bool ok = true;
  if (root) {
    ok = LockAndLoad(model_directory, log, &lock, &model, error) &&
         CheckReplaceable(model_directory, false, error) &&
         CheckExpectedDecoder(model_directory, model, expected, error);
    if (ok && restart &&
        (model.checkpoint.iterations > 0 || model.checkpoint.latent_refit_at >= 0)) {
      // Saved before training starts, so that a run killed before its first checkpoint
      // does not resume the old count next to a new log.
      model.checkpoint = TrainingCheckpoint();
      ok = SaveLearnedState(model_directory, model, error);
    }
  }
  if (distributed) {
    // The other ranks read the model once rank 0 holds the lock (and has cleaned up
    // after killed writers), then take rank 0's learned state.
    if (!communicator->Agree(ok, error)) return false;
    if (!root) ok = LoadModel(model_directory, &model, error);
    if (!ShareModel(*communicator, model_directory, ok, &model, error)) return false;
  }
  if (!ok) return false;
  TrainOptions train = options;
  // Only rank 0 writes checkpoints and the log.
  train.model_directory = root ? model_directory : std::string();
  TrainReport report;
  std::ostringstream quiet;
  if (!TrainEndToEnd(train, &model, &report, root ? log : quiet, error)) return false;
  if (!root) return true;
  // The error budget of the training poses, from the final equilibria.
  PretrainSurfaceErrors pretrain;
  std::string read_error;
  const bool have_pretrain = ReadPretrainSurfaceErrors(model_directory, model, &pretrain, &read_error);
  if (!read_error.empty()) log << "train: the pre-training record is unusable: " << read_error << "\n";
  std::vector<Eigen::Matrix3Xd> surfaces;
  for (int p = 0; p < model.num_poses(); ++p) {
    if (p >= static_cast<int>(model.states.size()) ||
        model.states[p].cols() != model.mesh.num_vertices()) {
      surfaces.clear();
      break;
    }
    surfaces.push_back(EmbeddedPositions(model.embedding, model.mesh.tets, model.states[p]));
  }
  log << "train: error budget over all surface vertices (model units): (a) the volumetric "
         "targets' embedded simulation, (b) the pre-trained decoder simulated"
      << (have_pretrain ? "" : " (not recorded: pre-trained without the record)")
      << ", (c) after end-to-end training\n"
      << TrainingBudgetTable(model, have_pretrain ? &pretrain : nullptr, surfaces);
  return true;
}

}  // namespace aqs
