#include "jobs/evaluate_job.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <functional>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

#include "dist/communicator.h"
#include "dist/model_sharing.h"
#include "eval/error_budget.h"
#include "eval/held_out_overlap.h"
#include "eval/surface_pca.h"
#include "geometry/points_near_model.h"
#include "jobs/held_out_fit_store.h"
#include "jobs/held_out_fits.h"
#include "jobs/report_script.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "model/model_io.h"
#include "prepare/pose_files.h"
#include "train/progress.h"
#include "util/atomic_file.h"
#include "util/blas.h"
#include "util/input_file.h"
#include "util/make_directory.h"
#include "util/fault_injection.h"
#include "util/keyed_store.h"
#include "util/matrix_io.h"
#include "util/memory_limit.h"
#include "util/option_checks.h"
#include "util/path_lock.h"
#include "util/vertex_ranges.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

// The output folder's subfolders a run empties before it writes: per-pose outputs and
// pictures (held_out_fits/, the fits' store, is kept: it resumes).
constexpr const char* kEmptiedEvaluationFolders[] = {"/fields", "/fitted", "/budget", "/images"};

// The file that marks a folder as an evaluation's (written at its first run).
constexpr char kEvaluationMarker[] = ".aqs-evaluation";

// Whether the evaluation may write into (and empty the output subfolders of) `out`: a
// folder that is empty, or that an evaluation wrote (kEvaluationMarker; or, from versions
// before the marker, evaluation.md or evaluation.csv). False with *error otherwise.
bool MayWriteEvaluationFolder(const std::string& out, std::string* error) {
  std::error_code code;
  if (std::filesystem::is_empty(out, code) && !code) return true;
  for (const char* name : {kEvaluationMarker, "evaluation.md", "evaluation.csv"}) {
    if (std::filesystem::exists(out + "/" + name, code)) return true;
  }
  *error = out + ": holds files, but no evaluation's (" + kEvaluationMarker +
           ", evaluation.md, evaluation.csv)" +
           ": an evaluation empties its fields/, fitted/, budget/ and images/; give "
           "--output_dir a new or empty folder, or an earlier evaluation's";
  return false;
}

// Removes the temporary files (util/atomic_file.h) that a killed evaluation left in its
// folder `out`: of its tables, of the auto-encoder's checkpoint and of the held-out
// fits' store; logs each. Call it holding the folder's lock.
bool RemoveStaleEvaluationFiles(const std::string& out, std::ostream& log, std::string* error) {
  auto is_store_item = [](const std::string& name) {
    // keyed_store.h: key.txt and NNNN.bin / NNNN.txt (4 digits or more).
    if (name == "key.txt") return true;
    const size_t dot = name.size() >= 8 ? name.size() - 4 : std::string::npos;
    if (dot == std::string::npos || (name.compare(dot, 4, ".bin") != 0 &&
                                     name.compare(dot, 4, ".txt") != 0)) {
      return false;
    }
    for (size_t i = 0; i < dot; ++i) {
      if (!std::isdigit(static_cast<unsigned char>(name[i]))) return false;
    }
    return true;
  };
  const std::vector<std::pair<std::string, std::function<bool(const std::string&)>>> folders = {
      {out,
       [](const std::string& n) {
         return n == "evaluation.md" || n == "evaluation.csv" || n == kEvaluationMarker;
       }},
      {out + "/" + kAutoencoderCheckpointFolder,
       [](const std::string& n) {
         return n == "checkpoint.txt" || n == "parameters_a.bin" || n == "parameters_b.bin";
       }},
      {out + "/" + kHeldOutFitFolder, is_store_item}};
  std::vector<std::string> removed;
  for (const auto& [folder, is_output] : folders) {
    if (!RemoveStaleTemporaryFiles(folder, is_output, &removed, error)) return false;
  }
  for (const std::string& line : removed) log << "cleanup: " << line << "\n";
  return true;
}

// The auto-encoder baseline's options: the model's latent size, and its decoder's
// layout, activation, anchoring and skip where the job's options do not set them.
SurfaceAutoencoderOptions BaselineAutoencoderOptions(const EvaluateJobOptions& options,
                                                     const ActiveModel& model) {
  const DecoderSpec& spec = model.decoder->spec();
  SurfaceAutoencoderOptions ae_options = options.autoencoder;
  ae_options.latent_dim = model.latent_dim();
  ae_options.hidden_dims =
      options.autoencoder_hidden_dims ? *options.autoencoder_hidden_dims : spec.hidden_dims;
  ae_options.activation = spec.activation;
  ae_options.anchored = spec.anchored;
  ae_options.linear_skip = options.autoencoder_linear_skip.value_or(spec.linear_skip);
  return ae_options;
}

// The trained model and the held-out poses, read and checked on every rank alike (each
// refuses bad input alike, before and at the collectives), and the output folders
// (rank 0). Collective when distributed.
bool ReadEvaluationInputs(const EvaluateJobOptions& options, bool distributed, bool root,
                          ActiveModel* model, std::vector<std::string>* test_names,
                          std::vector<Eigen::Matrix3Xd>* test_surfaces, PathLock* output_lock,
                          std::ostream& log, std::string* error) {
  const Communicator* communicator = options.communicator;
  if (options.model.empty() || options.output_directory.empty()) {
    *error = "--model and --output_dir are required";
    return false;
  }
  // Paths may resolve differently on another machine: the ranks agree.
  bool ok = CheckOutputApart(options.output_directory, options.model, error);
  // Nor may an input lie in the folders this job empties (a model kept there, a surface
  // an earlier evaluation wrote): they were deleted, and the run went on from memory.
  for (const char* folder : kEmptiedEvaluationFolders) {
    const std::string emptied = options.output_directory + folder;
    ok = ok && CheckInputOutside(options.model, emptied, error) &&
         CheckInputOutside(options.report_script, emptied, error);
    for (size_t t = 0; ok && t < options.test_paths.size(); ++t) {
      ok = CheckInputOutside(options.test_paths[t], emptied, error);
    }
  }
  if (distributed) ok = communicator->Agree(ok, error);
  if (!ok) return false;
  ok = LoadModel(options.model, model, error);
  if (ok && !model->decoder) {
    *error = options.model + ": the model is not trained (no decoder)";
    ok = false;
  }
  if (distributed) ok = ShareModel(*communicator, options.model, ok, model, error);
  if (!ok) return false;
  const int ns = model->num_surface_vertices();
  for (int v : options.error_vertices) {
    if (v >= ns) {
      *error = "error_vertices: error vertex " + std::to_string(v) + " is outside the surface's " +
               std::to_string(ns) + " vertices";
      return false;
    }
  }
  // The baseline's network, before any fit and before the output folders are emptied:
  // one too large fails only at its training, or aborts there (every rank sees the same
  // model and options); a refused run must not have deleted the last run's outputs.
  const double bytes = SurfaceAutoencoderMemoryBytes(BaselineAutoencoderOptions(options, *model),
                                                     ns, model->num_poses());
  if (!(bytes <= options.max_memory_bytes)) {
    *error = "autoencoder_hidden_dims: the auto-encoder baseline would take about " +
             FormatBytes(bytes) + " to train, above the memory limit of " +
             FormatBytes(options.max_memory_bytes) + " (max_memory_bytes)";
    return false;
  }
  ok = options.test_paths.empty() ||
       ReadPoseSurfaces(options.test_paths, ns, options.num_threads, test_names, test_surfaces,
                        error);
  for (size_t t = 0; ok && t < test_surfaces->size(); ++t) {
    ok = CheckPointsNearModel(options.test_paths[t], model->neutral.vertices, (*test_surfaces)[t],
                              error);
  }
  if (distributed) ok = communicator->Agree(ok, error);
  if (!ok) return false;
  if (distributed) {
    // Each rank read the poses on its own machine: they must be rank 0's, which scores
    // and stores every fit as a fit of its own.
    std::vector<std::string> fingerprints;
    for (const Eigen::Matrix3Xd& surface : *test_surfaces) {
      fingerprints.push_back(SurfaceFingerprint(surface));
    }
    int root_count = 0;
    const int unlike = communicator->FirstItemUnlikeRoot(fingerprints, &root_count);
    const int count = static_cast<int>(fingerprints.size());
    if (unlike >= 0) {
      if (unlike < count && unlike < root_count &&
          unlike < static_cast<int>(options.test_paths.size())) {
        *error = options.test_paths[unlike] + ": another surface here than rank 0 read";
      } else {
        *error = "the held-out poses: " + std::to_string(count) + " here, " +
                 std::to_string(root_count) + " on rank 0";
      }
      *error += " (every machine must hold the same held-out poses)";
    }
    if (!communicator->Agree(unlike < 0, error)) return false;
  }
  std::error_code code;
  const std::string& out = options.output_directory;
  if (root) {
    // One evaluation at a time writes into a folder (its writers' lock, held until the
    // job ends): two would empty each other's stores and outputs.
    std::filesystem::create_directories(out, code);
    if (code) {
      *error = out + ": cannot create the folder (" + code.message() + ")";
      ok = false;
    } else {
      ok = output_lock->Acquire(out, error, "the evaluation folder " + out);
    }
    // Only a folder of evaluations is emptied below: another folder (a project's, a
    // home) with a fields/, fitted/ or budget/ of its own is refused, never emptied.
    ok = ok && MayWriteEvaluationFolder(out, error);
    ok = ok && WriteFileAtomically(out + "/" + kEvaluationMarker,
                                   "An ActiveQS evaluation folder (aqs_evaluate).\n", error);
    // This job's per-pose outputs start empty: a method that writes nothing this run (a
    // failed fit, no error budget) must not leave an earlier run's file for the report
    // to draw, nor an earlier run's page and pictures stand for this run's when its
    // report is not written. (The held-out fits' store, held_out_fits/, is kept: it
    // resumes.)
    for (const char* folder : kEmptiedEvaluationFolders) {
      if (ok && !code) std::filesystem::remove_all(out + folder, code);
    }
    if (ok && !code) std::filesystem::remove(out + "/index.html", code);
    for (const char* folder : {"/fields", "/fitted"}) {
      if (ok && !code) std::filesystem::create_directories(out + folder, code);
    }
    if (ok && code) {
      *error = out + ": cannot create the output folders (" + code.message() + ")";
      ok = false;
    }
    if (ok && output_lock->first()) ok = RemoveStaleEvaluationFiles(out, log, error);
  }
  if (distributed) ok = communicator->Agree(ok, error);
  return ok;
}

// The warning for held-out poses that are training poses (a file listed twice, a
// mirror image); empty if none.
std::string HeldOutOverlapNote(const ActiveModel& model, const std::vector<std::string>& test_names,
                               const std::vector<Eigen::Matrix3Xd>& test_surfaces,
                               const std::vector<int>& error_vertices) {
  std::vector<Eigen::Matrix3Xd> training_surfaces;
  for (const TrainingPose& pose : model.poses) training_surfaces.push_back(pose.surface);
  std::ostringstream note;
  for (const HeldOutOverlap& overlap : FindHeldOutOverlaps(
           model.neutral.vertices, training_surfaces, test_surfaces, error_vertices)) {
    note << "held-out pose '" << test_names[overlap.test] << "' is within " << overlap.distance
         << " of the training pose '" << model.poses[overlap.training].name << "' (it moves "
         << overlap.motion << " from the neutral): it is not held out. ";
  }
  return note.str();
}

// The baselines of one evaluation, trained on the model's training poses.
struct Baselines {
  const SurfacePca& pca;          // about the training poses' mean
  const SurfacePca& pca_neutral;  // about the neutral
  const SurfaceAutoencoder& autoencoder;
};

// The training poses' rows: the neutral, the physics model (its training latents and
// bone motions, simulated from the equilibria training left: *trained_states), the
// auto-encoder (its training latents) and both PCAs (projections). The physics
// per-vertex errors go to column 3 p + 2 of *training_errors (num_surface_vertices x 3
// num_poses). False with *error naming the pose if a simulation fails.
bool EvaluateTrainingPoses(const ActiveModel& model, const Baselines& baselines,
                           const std::vector<int>& measured, LatentFitter* fitter,
                           std::vector<Eigen::Matrix3Xd>* trained_states,
                           Eigen::MatrixXd* training_errors, std::vector<EvaluationRow>* rows,
                           std::string* error) {
  const SurfaceAutoencoder& autoencoder = baselines.autoencoder;
  for (int p = 0; p < model.num_poses(); ++p) {
    const std::string& name = model.poses[p].name;
    const Eigen::Matrix3Xd& truth = model.poses[p].surface;
    fitter->set_bone_transforms(TrainingPoseBones(model, p));
    // From the equilibrium training left for this pose (the energy is not convex: from
    // rest a large pose such as jawOpen may crawl or reach another branch).
    fitter->StartFromTrainingPose(p);
    Eigen::Matrix3Xd surface;
    if (!fitter->Simulate(model.latents.col(p), &(*trained_states)[p], &surface, error)) {
      *error = "training pose '" + name + "': " + *error;
      return false;
    }
    rows->push_back(SummarizeErrors("train", name, kNeutralMethod,
                                    VertexErrors(model.neutral.vertices, truth), measured));
    training_errors->col(3 * p + 2) = VertexErrors(surface, truth);
    rows->push_back(
        SummarizeErrors("train", name, "physics", training_errors->col(3 * p + 2), measured));
    const Eigen::Matrix3Xd decoded = autoencoder.Decode(autoencoder.training_latents().col(p));
    rows->push_back(
        SummarizeErrors("train", name, "autoencoder", VertexErrors(decoded, truth), measured));
    const SurfacePca& pca = baselines.pca;
    rows->push_back(SummarizeErrors("train", name, "pca",
                                    VertexErrors(pca.Decode(pca.Encode(truth)), truth), measured));
    const SurfacePca& pca_neutral = baselines.pca_neutral;
    rows->push_back(SummarizeErrors("train", name, "pca_neutral",
                                    VertexErrors(pca_neutral.Decode(pca_neutral.Encode(truth)),
                                                 truth),
                                    measured));
  }
  return true;
}

// The training poses' error budget: (a) each pose's volumetric target simulated from rest
// (from its trained state where that does not converge; SimulateActuations), columns
// 3 p of *training_errors, "floor" rows, (b) the record of
// pre-training (columns 3 p + 1, "pretrain" rows); (c) is the physics rows. Sets
// parts->have_pretrain and counts floor failures in parts->floor_failures.
void TrainingPoseBudget(const EvaluateJobOptions& options, const ActiveModel& model,
                        const PoseSimulationOptions& simulation,
                        const std::vector<Eigen::Matrix3Xd>& trained_states,
                        Eigen::MatrixXd* training_errors, std::vector<EvaluationRow>* rows,
                        EvaluationReportParts* parts, std::ostream& log) {
  const std::vector<int>& measured = options.error_vertices;
  WallTimer timer;
  std::vector<ActuationMatrix> targets;
  std::vector<std::vector<RigidTransform>> bones;
  std::vector<Eigen::Matrix3Xd> starts;
  std::vector<int> with_target;
  for (int p = 0; p < model.num_poses(); ++p) {
    if (model.poses[p].target.cols() == 0) continue;
    with_target.push_back(p);
    targets.push_back(model.poses[p].target);
    bones.push_back(TrainingPoseBones(model, p));
    starts.push_back(trained_states[p]);
  }
  const std::vector<SimulatedPose> floors =
      SimulateActuations(model, targets, bones, starts, simulation);
  for (size_t k = 0; k < floors.size(); ++k) {
    const int p = with_target[k];
    if (!floors[k].converged) {
      ++parts->floor_failures;
      log << "  training pose '" << model.poses[p].name
          << "': its volumetric target's equilibrium did not converge (floor left out): "
          << floors[k].message << "\n";
      continue;
    }
    training_errors->col(3 * p) = VertexErrors(floors[k].surface, model.poses[p].surface);
    rows->push_back(SummarizeErrors("train", model.poses[p].name, "floor",
                                    training_errors->col(3 * p), measured));
  }
  PretrainSurfaceErrors pretrain;
  std::string read_error;
  parts->have_pretrain = ReadPretrainSurfaceErrors(options.model, model, &pretrain, &read_error);
  if (!read_error.empty()) {
    log << "  the pre-training record is unusable (stage (b) left out): " << read_error << "\n";
  }
  for (int p = 0; parts->have_pretrain && p < model.num_poses(); ++p) {
    if (!pretrain.converged[p]) {  // no equilibrium: no error to report
      ++parts->pretrain_unconverged;
      continue;
    }
    training_errors->col(3 * p + 1) = pretrain.distances.col(p);
    rows->push_back(SummarizeErrors("train", model.poses[p].name, "pretrain",
                                    Eigen::VectorXd(pretrain.distances.col(p)), measured));
  }
  log << "error budget: " << targets.size() << " volumetric targets simulated in "
      << FormatDuration(timer.Seconds()) << "; surface error after pre-training "
      << (parts->have_pretrain ? "from pretrain/surface_errors.*"
                               : "not recorded in the model (pre-trained without "
                                 "--pretrain_simulate or by an older version)")
      << "\n";
}

// A held-out pose's surfaces and per-vertex errors by method: physics, autoencoder,
// pca, pca_neutral, floor (the last only if made), and its fits' starts.
constexpr int kNumHeldOutSurfaces = 5;
const char* const kHeldOutSurfaceNames[kNumHeldOutSurfaces] = {"physics", "autoencoder", "pca",
                                                               "pca_neutral", "floor"};
struct HeldOut {
  Eigen::Matrix3Xd surfaces[kNumHeldOutSurfaces];
  Eigen::VectorXd errors[kNumHeldOutSurfaces];
  LatentFitResult fit;
  std::string ae_start;  // where the auto-encoder's latent fit started
};

// The held-out poses' rows: the neutral, the physics fit (`fits`, made before), the
// auto-encoder (its latent fitted to every vertex here) and both PCAs (projections);
// logs each pose. False with *error if an auto-encoder fit fails.
bool EvaluateHeldOutPoses(const EvaluateJobOptions& options, const ActiveModel& model,
                          const Baselines& baselines, const std::vector<std::string>& test_names,
                          const std::vector<Eigen::Matrix3Xd>& test_surfaces,
                          const std::vector<LatentFitResult>& fits,
                          const std::vector<double>& fit_seconds, std::vector<HeldOut>* held_out,
                          std::vector<EvaluationRow>* rows, std::ostream& log,
                          std::string* error) {
  const std::vector<int>& measured = options.error_vertices;
  const int ns = model.num_surface_vertices();
  std::vector<int> all(ns);
  for (int i = 0; i < ns; ++i) all[i] = i;
  held_out->assign(test_names.size(), HeldOut());
  for (size_t t = 0; t < test_names.size(); ++t) {
    WallTimer pose_timer;
    const Eigen::Matrix3Xd& truth = test_surfaces[t];
    HeldOut& h = (*held_out)[t];
    h.fit = fits[t];
    Eigen::VectorXd ae_latent;
    double ae_rms = 0;
    const SurfaceAutoencoder& autoencoder = baselines.autoencoder;
    // The same priors as the physics fit (options.fit), learned from its own latents.
    const Eigen::VectorXd ae_start = AutoencoderStart(
        autoencoder, model, truth, options.fit, options.training_pose_starts, &h.ae_start);
    if (!autoencoder.FitLatent(all, truth, ae_start, options.fit, &ae_latent, &ae_rms)) {
      *error = "held-out pose '" + test_names[t] + "': the auto-encoder's latent fit failed";
      return false;
    }
    rows->push_back(SummarizeErrors("test", test_names[t], kNeutralMethod,
                                    VertexErrors(model.neutral.vertices, truth), measured));
    // A failed physics fit has no surface: its row is left out (n/a in the tables).
    if (!h.fit.failed) h.surfaces[0] = h.fit.surface;
    h.surfaces[1] = autoencoder.Decode(ae_latent);
    h.surfaces[2] = baselines.pca.Decode(baselines.pca.Encode(truth));
    h.surfaces[3] = baselines.pca_neutral.Decode(baselines.pca_neutral.Encode(truth));
    std::ostringstream means;
    means << "neutral " << rows->back().mean;
    for (int m = 0; m < kNumEvaluationMethods; ++m) {
      if (h.surfaces[m].cols() == 0) {
        means << ", " << kEvaluationMethods[m] << " n/a";
        continue;
      }
      h.errors[m] = VertexErrors(h.surfaces[m], truth);
      rows->push_back(
          SummarizeErrors("test", test_names[t], kEvaluationMethods[m], h.errors[m], measured));
      means << ", " << kEvaluationMethods[m] << " " << rows->back().mean;
    }
    log << "  " << test_names[t] << ": fitted in "
        << FormatDuration(fit_seconds[t] + pose_timer.Seconds()) << " (physics ";
    if (h.fit.failed) {
      log << "fit FAILED, left out: " << h.fit.message;
    } else {
      log << h.fit.iterations << " iterations from " << h.fit.start;
    }
    log << ", auto-encoder from " << h.ae_start << "), mean error: " << means.str() << "\n";
  }
  return true;
}

// The held-out poses' floor: their own volumetric targets (prepare's embedded
// simulation, bones where the physics fit put them), simulated: surfaces and errors
// [4] of *held_out and "floor" rows. Sets parts->have_held_out_floor and counts
// failures in parts->floor_failures (a pose whose target or its simulation does not
// converge loses its floor alone; each is logged).
void HeldOutFloors(const EvaluateJobOptions& options, const ActiveModel& model,
                   const PoseSimulationOptions& simulation,
                   const std::vector<std::string>& test_names,
                   const std::vector<Eigen::Matrix3Xd>& test_surfaces,
                   std::vector<HeldOut>* held_out, std::vector<EvaluationRow>* rows,
                   EvaluationReportParts* parts, std::ostream& log) {
  WallTimer timer;
  ActiveModel held = model;
  held.poses.clear();
  held.states.clear();
  for (Bone& bone : held.bones) bone.pose_transforms.clear();
  const std::vector<RigidTransform> rest = RestBoneTransforms(model);
  for (size_t t = 0; t < test_names.size(); ++t) {
    TrainingPose pose;
    pose.name = test_names[t];
    pose.surface = test_surfaces[t];
    held.poses.push_back(pose);
    // Bones where the physics fit put them (at rest where it failed).
    const LatentFitResult& fit = (*held_out)[t].fit;
    for (size_t b = 0; b < held.bones.size(); ++b) {
      held.bones[b].pose_transforms.push_back(fit.failed ? rest[b] : fit.bones[b]);
    }
  }
  std::ostringstream target_log;
  VolumetricTargetOptions target_options = options.held_out_targets;
  target_options.num_threads = options.num_threads;
  std::string target_error;
  if (!target_options.Validate(&target_error)) {
    log << "  the held-out poses' volumetric targets failed (their floor is left out): "
        << target_error << "\n";
    return;
  }
  // A pose whose target's embedded simulation does not converge loses its floor alone.
  // (Not for a pose whose floor is left out below: its fit failed, with bones.)
  std::vector<int> made;
  for (size_t t = 0; t < test_names.size(); ++t) {
    if (!(*held_out)[t].fit.failed || model.bones.empty()) made.push_back(static_cast<int>(t));
  }
  std::vector<std::string> target_failures(test_names.size());
  MakeVolumetricTargetsOf(target_options, made, nullptr, &held, target_log, &target_failures);
  std::vector<int> simulated;  // the poses with a target
  std::vector<ActuationMatrix> targets;
  std::vector<std::vector<RigidTransform>> bones;
  std::vector<Eigen::Matrix3Xd> starts;
  for (size_t t = 0; t < test_names.size(); ++t) {
    // A failed fit placed no bones: a floor with them at rest would be another pose's (a
    // jaw pose's target with the jaw closed), so a model with bones leaves it out.
    if ((*held_out)[t].fit.failed && !model.bones.empty()) {
      ++parts->floor_without_fit;
      log << "  held-out pose '" << test_names[t]
          << "': its physics fit failed, which places the bones (floor left out)\n";
      continue;
    }
    if (!target_failures[t].empty()) {
      ++parts->floor_failures;
      log << "  held-out pose '" << test_names[t]
          << "': its volumetric target did not converge (floor left out): "
          << target_failures[t] << "\n";
      continue;
    }
    simulated.push_back(static_cast<int>(t));
    targets.push_back(held.poses[t].target);
    const LatentFitResult& fit = (*held_out)[t].fit;
    bones.push_back(fit.failed ? rest : fit.bones);
    starts.push_back(fit.failed ? model.mesh.vertices : fit.state);
  }
  const std::vector<SimulatedPose> floors =
      SimulateActuations(model, targets, bones, starts, simulation);
  parts->have_held_out_floor = true;
  for (size_t k = 0; k < simulated.size(); ++k) {
    const int t = simulated[k];
    if (!floors[k].converged) {
      ++parts->floor_failures;
      log << "  held-out pose '" << test_names[t]
          << "': its volumetric target's equilibrium did not converge (floor left out): "
          << floors[k].message << "\n";
      continue;
    }
    HeldOut& h = (*held_out)[t];
    h.surfaces[4] = floors[k].surface;
    h.errors[4] = VertexErrors(floors[k].surface, test_surfaces[t]);
    rows->push_back(
        SummarizeErrors("test", test_names[t], "floor", h.errors[4], options.error_vertices));
  }
  log << "error budget: the held-out poses' volumetric targets made and simulated in "
      << FormatDuration(timer.Seconds()) << "\n";
}

// For each held-out pose: fitted/<pose>_target.obj (the pose), and per method
// fitted/<pose>_<method>.obj and fields/<pose>_<method>.ply (its per-vertex errors, on
// one colour scale for the pose's methods).
bool WriteHeldOutFields(const std::string& out, const ActiveModel& model,
                        const std::vector<std::string>& test_names,
                        const std::vector<Eigen::Matrix3Xd>& test_surfaces,
                        const std::vector<HeldOut>& held_out,
                        const std::vector<int>& error_vertices, std::string* error) {
  for (size_t t = 0; t < test_names.size(); ++t) {
    const HeldOut& h = held_out[t];
    // One colour scale for the methods of a pose, the report's pictures' own
    // (ErrorMapScale), so that the fields compare by eye, with each other and with them.
    std::vector<double> pooled;
    for (const Eigen::VectorXd& e : h.errors) {
      if (e.size() == 0) continue;
      if (error_vertices.empty()) {
        pooled.insert(pooled.end(), e.data(), e.data() + e.size());
      } else {
        for (int v : error_vertices) pooled.push_back(e[v]);
      }
    }
    const double color_max = ErrorMapScale(std::move(pooled));
    SurfaceMesh surface = model.neutral;
    surface.vertices = test_surfaces[t];
    if (!WriteObj(out + "/fitted/" + test_names[t] + "_target.obj", surface, error)) return false;
    for (int m = 0; m < kNumHeldOutSurfaces; ++m) {
      if (h.surfaces[m].cols() == 0) continue;
      surface.vertices = h.surfaces[m];
      const std::string stem = test_names[t] + "_" + kHeldOutSurfaceNames[m];
      const Eigen::VectorXd& e = h.errors[m];
      const std::vector<double> values(e.data(), e.data() + e.size());
      if (!WriteObj(out + "/fitted/" + stem + ".obj", surface, error) ||
          !WritePlyWithScalar(out + "/fields/" + stem + ".ply", surface, values, color_max,
                              error)) {
        return false;
      }
    }
  }
  return true;
}

}  // namespace

bool EvaluateJobOptions::Validate(std::string* error) const {
  std::string fit_error, autoencoder_error, targets_error;
  const bool fit_ok = fit.Validate(&fit_error);
  const bool autoencoder_ok = autoencoder.Validate(&autoencoder_error);
  const bool targets_ok = held_out_targets.Validate(&targets_error);
  bool widths_ok = true;
  if (autoencoder_hidden_dims) {
    for (int width : *autoencoder_hidden_dims) widths_ok = widths_ok && width > 0;
  }
  return OptionChecks()
      .Nested("fit", fit_ok, fit_error)
      .Nested("autoencoder", autoencoder_ok, autoencoder_error)
      .Require(widths_ok, "autoencoder_hidden_dims: every width must be > 0")
      .Require(std::all_of(error_vertices.begin(), error_vertices.end(),
                           [](int v) { return v >= 0; }),
               "error_vertices: every vertex index must be >= 0")
      .Nested("held_out_targets", targets_ok, targets_error)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .Positive("max_memory_bytes", max_memory_bytes)
      .Done(error);
}

bool RunEvaluateJob(const EvaluateJobOptions& options, std::ostream& job_log,
                    std::vector<EvaluationRow>* rows_out, std::string* error) {
  WallTimer total;
  // The same options on every rank: each refuses them alike, before any collective.
  if (!options.Validate(error)) return false;
  const Communicator* communicator = options.communicator;
  const bool distributed = communicator != nullptr && communicator->size() > 1;
  const bool root = !distributed || communicator->is_root();
  std::ostringstream quiet;  // the other ranks' log
  std::ostream& log = root ? job_log : quiet;
  ActiveModel model;
  std::vector<std::string> test_names;
  std::vector<Eigen::Matrix3Xd> test_surfaces;
  PathLock output_lock;  // rank 0's, until the job ends
  if (!ReadEvaluationInputs(options, distributed, root, &model, &test_names, &test_surfaces,
                            &output_lock, log, error)) {
    return false;
  }
  const int ns = model.num_surface_vertices();
  const std::string& out = options.output_directory;
  EvaluationReportParts parts;
  parts.model = options.model;
  parts.num_error_vertices =
      options.error_vertices.empty() ? ns : static_cast<int>(options.error_vertices.size());
  parts.latent_dim = model.latent_dim();
  parts.test_names = test_names;
  parts.training_pose_starts = options.training_pose_starts;
  parts.error_budget = options.error_budget;
  log << "evaluate: " << model.num_poses() << " training poses, " << test_names.size()
      << " held-out poses, latent " << model.latent_dim() << ", errors over "
      << parts.num_error_vertices << " surface vertices\n";
  parts.overlap_note =
      HeldOutOverlapNote(model, test_names, test_surfaces, options.error_vertices);
  if (!parts.overlap_note.empty()) log << "warning: " << parts.overlap_note << "\n";
  // The physics fits of the held-out poses first: the part shared among ranks.
  // Kept as they come (removed at the end), so that a rerun after a stop goes on.
  const std::string fit_store = out + "/" + kHeldOutFitFolder;
  WallTimer timer;
  HeldOutFits held_out_fits;
  FitHeldOutPoses(model, options.fit, options.training_pose_starts, test_names, test_surfaces,
                  fit_store, communicator, &held_out_fits);
  if (!test_names.empty()) {
    log << "held-out poses: " << test_names.size() - held_out_fits.kept << " physics fits in "
        << FormatDuration(timer.Seconds())
        << (distributed ? " over " + communicator->Description() : std::string());
    if (held_out_fits.kept > 0) {
      log << ", " << held_out_fits.kept << " taken from " << fit_store << " (a stopped run's)";
    }
    log << "\n";
    if (!held_out_fits.store_warning.empty()) {
      log << "warning: " << held_out_fits.store_warning << "\n";
    }
  }
  if (!root) return true;
  const std::vector<LatentFitResult>& fits = held_out_fits.fits;
  const std::vector<double>& fit_seconds = held_out_fits.seconds;

  // The baselines, trained on the same poses with the same latent size.
  std::vector<Eigen::Matrix3Xd> train_surfaces;
  for (const TrainingPose& pose : model.poses) train_surfaces.push_back(pose.surface);
  timer.Reset();
  const SurfacePca pca(train_surfaces, model.latent_dim());
  const SurfacePca pca_neutral(train_surfaces, model.latent_dim(), &model.neutral.vertices);
  SurfaceAutoencoderOptions ae_options = BaselineAutoencoderOptions(options, model);
  // Checkpoints of the baseline's training (the evaluation's longest part on the full
  // face: 8.5 minutes), so that a rerun after a stop resumes it; removed at the end.
  ae_options.checkpoint_directory = out + "/" + kAutoencoderCheckpointFolder;
  SurfaceAutoencoder autoencoder;
  if (!autoencoder.Train(model.neutral.vertices, train_surfaces, ae_options, log, error)) {
    *error = "the auto-encoder baseline: " + *error;
    return false;
  }
  log << "baselines: PCA with " << pca.num_components() << " components; auto-encoder trained in "
      << FormatDuration(timer.Seconds()) << " (rms " << autoencoder.report().rms_error << ")\n";
  const Baselines baselines{pca, pca_neutral, autoencoder};
  const DecoderSpec& spec = model.decoder->spec();
  parts.decoder_hidden_dims = spec.hidden_dims;
  parts.autoencoder_hidden_dims = ae_options.hidden_dims;
  parts.decoder_anchored = spec.anchored;
  parts.decoder_linear_skip = spec.linear_skip;
  parts.autoencoder_linear_skip = ae_options.linear_skip;
  const SurfaceAutoencoderReport& ae = autoencoder.report();
  parts.autoencoder_iterations = ae.iterations;
  parts.autoencoder_restarts = ae.restarts;
  parts.autoencoder_resumed_after = ae.iterations_before;
  parts.physics_fits_kept = held_out_fits.kept;
  parts.autoencoder_scaled_steps = ae_options.lbfgs_scaling;
  parts.autoencoder_seed = ae_options.seed;
  parts.num_bones = static_cast<int>(model.bones.size());
  parts.trained_iterations = model.checkpoint.iterations;
  parts.autoencoder_initial_loss = ae.initial_loss;
  parts.autoencoder_resumed_loss = ae.resumed_loss;
  parts.autoencoder_final_loss = ae.final_loss;
  parts.autoencoder_termination = ae.termination;
  parts.pca_components = pca.num_components();
  parts.pca_neutral_components = pca_neutral.num_components();
  parts.latent_prior = options.fit.latent_prior;
  parts.prior_points_cap = options.fit.prior_points_cap;
  parts.fit_latent_regularization = options.fit.latent_regularization;

  // Training poses.
  std::vector<EvaluationRow> rows;
  LatentFitter fitter(model, options.fit);
  // BLAS threads for this model's factor size (util/blas.h).
  const ScopedBlasThreads blas(BlasThreadsForFactor(fitter.FactorNonzeros(), BlasThreads()));
  std::vector<Eigen::Matrix3Xd> trained_states(model.num_poses());
  // Per training pose the budget's per-vertex errors: floor, after pre-training,
  // trained (NaN where not measured), for the report's pictures.
  Eigen::MatrixXd training_errors = Eigen::MatrixXd::Constant(
      ns, 3 * model.num_poses(), std::numeric_limits<double>::quiet_NaN());
  if (!EvaluateTrainingPoses(model, baselines, options.error_vertices, &fitter, &trained_states,
                             &training_errors, &rows, error)) {
    return false;
  }
  PoseSimulationOptions budget_simulation;
  budget_simulation.solver = options.fit.solver;
  budget_simulation.num_threads = options.num_threads;
  if (options.error_budget) {
    TrainingPoseBudget(options, model, budget_simulation, trained_states, &training_errors,
                       &rows, &parts, log);
  }

  // Held-out poses.
  std::vector<HeldOut> held_out;
  if (!EvaluateHeldOutPoses(options, model, baselines, test_names, test_surfaces, fits,
                            fit_seconds, &held_out, &rows, log, error)) {
    return false;
  }
  for (const HeldOut& h : held_out) {
    parts.physics_starts.push_back(h.fit.start);
    parts.autoencoder_starts.push_back(h.ae_start);
    parts.fit_failures += h.fit.failed ? 1 : 0;
  }
  if (options.error_budget && !test_names.empty()) {
    HeldOutFloors(options, model, budget_simulation, test_names, test_surfaces, &held_out, &rows,
                  &parts, log);
  }
  if (options.write_fields && options.error_budget) {
    std::error_code code;
    std::filesystem::create_directories(out + "/budget", code);
    if (code || !WriteMatrixFile(out + "/budget/training_errors.bin", training_errors, error)) {
      if (code) *error = out + "/budget: cannot create the folder (" + code.message() + ")";
      return false;
    }
  }
  if (options.write_fields &&
      !WriteHeldOutFields(out, model, test_names, test_surfaces, held_out,
                          options.error_vertices, error)) {
    return false;
  }

  // Tables.
  const EvaluationTables tables = MakeEvaluationTables(rows, parts);
  if (!WriteFileAtomically(out + "/evaluation.md", EvaluationMarkdown(parts, tables), error) ||
      !WriteFileAtomically(out + "/evaluation.csv", EvaluationCsv(rows), error)) {
    return false;
  }
  log << "\n" << tables.train << "\n" << tables.test << "\n" << tables.budget << "\nwrote " << out
      << "/evaluation.md, " << out << "/evaluation.csv"
      << (options.write_fields ? ", fields/*.ply, fitted/*.obj" : "") << " ("
      << FormatDuration(total.Seconds()) << ")\n";
  *rows_out = rows;
  if (!options.report_script.empty()) {
    std::vector<std::string> arguments = {"--evaluation", out, "--model", options.model};
    if (!options.error_vertices.empty()) {
      arguments.push_back("--error_vertices");
      arguments.push_back(FormatVertexRanges(options.error_vertices));
    }
    RunReportScript(options.python, options.report_script, arguments, log);
  }
  // The stores of the fits and of the auto-encoder's checkpoint go once the report is
  // done: a run killed while the report draws resumes from them (it retrained the
  // auto-encoder and refitted every pose, 11 to 20 minutes on the full face).
  FaultPoint("evaluate:reported");
  for (const std::string& kept : {ae_options.checkpoint_directory, fit_store,
                                   KeyedStore::PreviousPath(fit_store)}) {
    std::string remove_error;
    if (!RemoveDirectory(kept, &remove_error)) log << "warning: " << remove_error << "\n";
  }
  return true;
}

}  // namespace aqs
