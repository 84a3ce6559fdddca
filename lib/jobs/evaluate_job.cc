#include "jobs/evaluate_job.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>
#include <utility>

#include "dist/communicator.h"
#include "dist/model_sharing.h"
#include "eval/error_budget.h"
#include "eval/held_out_overlap.h"
#include "eval/surface_pca.h"
#include "fit/chosen_start_fit.h"
#include "geometry/points_near_model.h"
#include "jobs/report_script.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "model/model_io.h"
#include "prepare/pose_files.h"
#include "train/progress.h"
#include "util/atomic_file.h"
#include "util/blas.h"
#include "util/line_reader.h"
#include "util/matrix_io.h"
#include "util/wall_timer.h"
#include "util/option_checks.h"
#include "util/vertex_ranges.h"

namespace aqs {
namespace {

// pca_neutral: PCA about the neutral (uncentered displacements), the linear model whose
// zero is the rest, like an anchored decoder's (SurfacePca).
const char* const kMethods[4] = {"physics", "autoencoder", "pca", "pca_neutral"};
// The reference row of every pose: the neutral surface itself (no motion).
const char* const kNeutral = "neutral";

// Distances of the listed vertices (all if empty).
Eigen::VectorXd VertexErrors(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  return (a - b).colwise().norm().transpose();
}

EvaluationRow Summarize(const std::string& split, const std::string& pose, const char* method,
                        const Eigen::VectorXd& errors, const std::vector<int>& vertices) {
  EvaluationRow row;
  row.split = split;
  row.pose = pose;
  row.method = method;
  double sum = 0, squares = 0, worst = 0;
  int n = 0;
  auto add = [&](double e) {
    sum += e;
    squares += e * e;
    worst = std::max(worst, e);
    ++n;
  };
  if (vertices.empty()) {
    for (Eigen::Index i = 0; i < errors.size(); ++i) add(errors[i]);
  } else {
    for (int v : vertices) add(errors[v]);
  }
  row.mean = n > 0 ? sum / n : 0;
  row.rms = n > 0 ? std::sqrt(squares / n) : 0;
  row.max = worst;
  return row;
}

std::string Number(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.4f", v);
  return text;
}

std::string MarkdownTable(const std::vector<EvaluationRow>& rows, const std::string& split) {
  // pose -> method -> row
  std::vector<std::string> poses;
  std::map<std::string, std::map<std::string, EvaluationRow>> table;
  for (const EvaluationRow& row : rows) {
    if (row.split != split) continue;
    if (table.find(row.pose) == table.end()) poses.push_back(row.pose);
    table[row.pose][row.method] = row;
  }
  if (poses.empty()) return "";
  std::string out = "| " + split + " pose | neutral mean | physics mean | rms | max | autoencoder mean | "
                    "rms | max | PCA mean | rms | max | PCA (neutral) mean | rms | max |\n"
                    "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  std::map<std::string, EvaluationRow> average;
  double neutral_average = 0;
  for (const std::string& pose : poses) {
    const auto neutral = table[pose].find(kNeutral);
    const double neutral_mean = neutral == table[pose].end() ? 0.0 : neutral->second.mean;
    neutral_average += neutral_mean / poses.size();
    out += "| " + pose + " | " + Number(neutral_mean);
    for (const char* method : kMethods) {
      const EvaluationRow& r = table[pose][method];
      out += " | " + Number(r.mean) + " | " + Number(r.rms) + " | " + Number(r.max);
      EvaluationRow& a = average[method];
      a.mean += r.mean / poses.size();
      a.rms += r.rms / poses.size();
      a.max = std::max(a.max, r.max);
    }
    out += " |\n";
  }
  out += "| **mean** (max of max) | " + Number(neutral_average);
  for (const char* method : kMethods) {
    const EvaluationRow& a = average[method];
    out += " | **" + Number(a.mean) + "** | " + Number(a.rms) + " | " + Number(a.max);
  }
  out += " |\n";
  return out;
}

// The error budget as Markdown: per pose the mean error of each stage, then the mean
// over poses and the largest vertex error. `columns`: (method, heading) in order; a
// method without a row for a pose shows "n/a".
std::string BudgetTable(const std::vector<EvaluationRow>& rows, const std::string& split,
                        const std::vector<std::pair<std::string, std::string>>& columns) {
  std::vector<std::string> poses;
  std::map<std::string, std::map<std::string, EvaluationRow>> table;
  for (const EvaluationRow& row : rows) {
    if (row.split != split) continue;
    if (table.find(row.pose) == table.end()) poses.push_back(row.pose);
    table[row.pose][row.method] = row;
  }
  if (poses.empty()) return "";
  std::string out = "| " + split + " pose |";
  std::string rule = "|---|";
  for (const auto& column : columns) {
    out += " " + column.second + " |";
    rule += "---:|";
  }
  out += "\n" + rule + "\n";
  std::vector<double> sum(columns.size(), 0.0), worst(columns.size(), 0.0);
  std::vector<int> count(columns.size(), 0);
  for (const std::string& pose : poses) {
    out += "| " + pose;
    for (size_t c = 0; c < columns.size(); ++c) {
      const auto it = table[pose].find(columns[c].first);
      if (it == table[pose].end()) {
        out += " | n/a";
        continue;
      }
      out += " | " + Number(it->second.mean);
      sum[c] += it->second.mean;
      worst[c] = std::max(worst[c], it->second.max);
      ++count[c];
    }
    out += " |\n";
  }
  out += "| **mean**";
  for (size_t c = 0; c < columns.size(); ++c) {
    out += count[c] == static_cast<int>(poses.size()) ? " | **" + Number(sum[c] / count[c]) + "**"
                                                       : std::string(" | n/a");
  }
  out += " |\n| max vertex error";
  for (size_t c = 0; c < columns.size(); ++c) {
    out += count[c] > 0 ? " | " + Number(worst[c]) : std::string(" |");
  }
  out += " |\n";
  return out;
}

// How the report names the start at the mean training latent.
constexpr char kMeanLatentStart[] = "mean latent";

// The start of the auto-encoder's latent fit to `truth` (3 x N, every surface vertex):
// its mean training latent or, with training_pose_starts, whichever of that
// and its trained latents (in the order of model.poses) has the smallest FitLatent
// objective (1/N) sum_v |surface_v(z) - y_v|^2 + lambda |z|^2. *name: "mean latent" or
// the pose's name.
Eigen::VectorXd AutoencoderStart(const SurfaceAutoencoder& autoencoder, const ActiveModel& model,
                                 const Eigen::Matrix3Xd& truth, bool training_pose_starts,
                                 std::string* name) {
  const double lambda = autoencoder.options().latent_regularization;
  auto objective = [&](const Eigen::VectorXd& z) {
    return (autoencoder.Decode(z) - truth).squaredNorm() / truth.cols() + lambda * z.squaredNorm();
  };
  Eigen::VectorXd best = autoencoder.MeanLatent();
  *name = kMeanLatentStart;
  if (!training_pose_starts) return best;
  double best_value = objective(best);
  const Eigen::MatrixXd& latents = autoencoder.training_latents();
  for (int p = 0; p < static_cast<int>(latents.cols()) && p < model.num_poses(); ++p) {
    const double value = objective(latents.col(p));
    if (value < best_value) {
      best_value = value;
      best = latents.col(p);
      *name = model.poses[p].name;
    }
  }
  return best;
}

// A held-out fit's start as a number, to gather it among ranks: the training pose's
// index, or -1 for the mean training latent; and back.
int StartIndex(const ActiveModel& model, const std::string& start) {
  for (int p = 0; p < model.num_poses(); ++p) {
    if (model.poses[p].name == start) return p;
  }
  return -1;
}
std::string StartName(const ActiveModel& model, int index) {
  return index >= 0 && index < model.num_poses() ? model.poses[index].name : kMeanLatentStart;
}

// The physics fits of the held-out poses (each with a fitter of its own, from the mean
// training latent at rest or, with training_pose_starts, from the best of that and the
// training poses; LatentFitResult::start names it),
// shared among the ranks of `communicator` (null: one process): pose t is fitted by
// rank t % size, and rank 0 receives every result (*fits, *seconds: each fit's wall
// time on its rank). Collective; false with *error on every rank if a fit fails (the
// first failing pose's message).
bool FitHeldOutPoses(const ActiveModel& model, const LatentFitOptions& options,
                     bool training_pose_starts, const std::vector<std::string>& names,
                     const std::vector<Eigen::Matrix3Xd>& surfaces,
                     const Communicator* communicator, std::vector<LatentFitResult>* fits,
                     std::vector<double>* seconds, std::string* error) {
  const int count = static_cast<int>(names.size());
  const int rank = communicator == nullptr ? 0 : communicator->rank();
  const int size = communicator == nullptr ? 1 : communicator->size();
  fits->assign(count, LatentFitResult());
  seconds->assign(count, 0.0);
  int first_failure = count;
  std::string failure;
  for (int t : OwnedIndices(count, rank, size)) {
    WallTimer timer;
    LatentFitter fitter(model, options);
    fitter.set_bone_transforms(RestBoneTransforms(model));
    fitter.set_start_state(model.mesh.vertices);  // from rest: order-independent
    const FitTarget target = FullSurfaceTarget(surfaces[t]);
    LatentFitResult& fit = (*fits)[t];
    FitStartOptions start_options;
    start_options.training_poses = training_pose_starts;
    if (!FitFromChosenStart(&fitter, &target, nullptr, PointCloudFitOptions(), start_options,
                            fitter.MeanLatent(), &fit, &failure)) {
      failure = "held-out pose '" + names[t] + "': " + failure;
      first_failure = t;
      break;
    }
    if (fit.start == "given") fit.start = kMeanLatentStart;
    (*seconds)[t] = timer.Seconds();
  }
  if (size == 1) {
    if (first_failure < count) *error = failure;
    return first_failure == count;
  }
  communicator->MinToAll(&first_failure, 1);
  if (first_failure < count) {
    communicator->BroadcastText(&failure, first_failure % size);
    *error = failure;
    return false;
  }
  // Rank 0 gathers every fit: latent, bones, state, surface, errors, counts, seconds.
  const int d = model.latent_dim();
  const int nb = static_cast<int>(model.bones.size());
  const int nv = model.mesh.num_vertices();
  const int ns = model.num_surface_vertices();
  const int block = d + 12 * nb + 3 * nv + 3 * ns + 8;
  std::vector<double> send;
  for (int t : OwnedIndices(count, rank, size)) {
    const LatentFitResult& f = (*fits)[t];
    send.insert(send.end(), f.latent.data(), f.latent.data() + d);
    for (const RigidTransform& b : f.bones) {
      send.insert(send.end(), b.rotation.data(), b.rotation.data() + 9);
      send.insert(send.end(), b.translation.data(), b.translation.data() + 3);
    }
    send.insert(send.end(), f.state.data(), f.state.data() + 3 * nv);
    send.insert(send.end(), f.surface.data(), f.surface.data() + 3 * ns);
    send.insert(send.end(), {f.rms_error, f.mean_error, f.max_error, double(f.iterations),
                             double(f.used_points), f.converged ? 1.0 : 0.0, (*seconds)[t],
                             double(StartIndex(model, f.start))});
  }
  std::vector<int> counts(size);
  for (int r = 0; r < size; ++r) counts[r] = block * static_cast<int>(OwnedIndices(count, r, size).size());
  std::vector<double> received(rank == 0 ? static_cast<size_t>(block) * count : 0);
  communicator->GatherToRoot(send.data(), counts, received.data());
  if (rank != 0) return true;
  const double* x = received.data();
  for (int r = 0; r < size; ++r) {
    for (int t : OwnedIndices(count, r, size)) {
      LatentFitResult& f = (*fits)[t];
      f.latent = Eigen::Map<const Eigen::VectorXd>(x, d);
      x += d;
      f.bones.assign(nb, RigidTransform());
      for (RigidTransform& b : f.bones) {
        b.rotation = Eigen::Map<const Eigen::Matrix3d>(x);
        b.translation = Eigen::Map<const Eigen::Vector3d>(x + 9);
        x += 12;
      }
      f.state = Eigen::Map<const Eigen::Matrix3Xd>(x, 3, nv);
      x += 3 * nv;
      f.surface = Eigen::Map<const Eigen::Matrix3Xd>(x, 3, ns);
      x += 3 * ns;
      f.rms_error = x[0];
      f.mean_error = x[1];
      f.max_error = x[2];
      f.iterations = static_cast<int>(x[3]);
      f.used_points = static_cast<int>(x[4]);
      f.converged = x[5] != 0.0;
      (*seconds)[t] = x[6];
      f.start = StartName(model, static_cast<int>(x[7]));
      x += 8;
    }
  }
  return true;
}

// How the auto-encoder's hidden layers compare with the decoder's, for the report.
std::string LayoutNote(const std::vector<int>& decoder, const std::vector<int>& autoencoder) {
  if (decoder == autoencoder) return "the same network layout";
  auto widths = [](const std::vector<int>& w) {
    if (w.empty()) return std::string("none (linear)");
    std::string text;
    for (size_t i = 0; i < w.size(); ++i) text += (i ? "," : "") + std::to_string(w[i]);
    return text;
  };
  return "hidden layers " + widths(autoencoder) + " (the physics decoder's: " + widths(decoder) +
         ")";
}

// How the auto-encoder's linear skip compares with the decoder's, for the report.
std::string SkipNote(bool decoder, bool autoencoder) {
  if (decoder == autoencoder) return decoder ? " and the same linear skip" : "";
  return autoencoder ? " and a linear skip (the physics decoder has none)"
                     : " and no linear skip (the physics decoder has one)";
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
      .Nested("held_out_targets", targets_ok, targets_error)
      .IntInRange("num_threads", num_threads, 1, 1024)
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
  if (options.model.empty() || options.output_directory.empty()) {
    *error = "--model and --output_dir are required";
    return false;
  }
  ActiveModel model;
  bool ok = LoadModel(options.model, &model, error);
  if (ok && !model.decoder) {
    *error = options.model + ": the model is not trained (no decoder)";
    ok = false;
  }
  if (distributed) ok = ShareModel(*communicator, options.model, ok, &model, error);
  if (!ok) return false;
  const int ns = model.num_surface_vertices();
  for (int v : options.error_vertices) {
    if (v >= ns) {
      *error = "error vertex " + std::to_string(v) + " is outside the surface's " +
               std::to_string(ns) + " vertices";
      return false;
    }
  }
  std::vector<std::string> test_names;
  std::vector<Eigen::Matrix3Xd> test_surfaces;
  ok = options.test_paths.empty() ||
       ReadPoseSurfaces(options.test_paths, ns, options.num_threads, &test_names, &test_surfaces,
                        error);
  for (size_t t = 0; ok && t < test_surfaces.size(); ++t) {
    ok = CheckPointsNearModel(options.test_paths[t], model.neutral.vertices, test_surfaces[t],
                              error);
  }
  if (distributed) ok = communicator->Agree(ok, error);
  if (!ok) return false;
  std::error_code code;
  const std::string out = options.output_directory;
  if (root) {
    std::filesystem::create_directories(out + "/fields", code);
    std::filesystem::create_directories(out + "/fitted", code);
    if (code) *error = out + ": cannot create the output folders (" + code.message() + ")";
  }
  ok = !code;
  if (distributed) ok = communicator->Agree(ok, error);
  if (!ok) return false;
  const int num_error_vertices =
      options.error_vertices.empty() ? ns : static_cast<int>(options.error_vertices.size());
  log << "evaluate: " << model.num_poses() << " training poses, " << test_names.size()
      << " held-out poses, latent " << model.latent_dim() << ", errors over "
      << num_error_vertices << " surface vertices\n";
  // Held-out poses that are training poses (a file listed twice, a mirror image).
  std::string overlap_note;
  {
    std::vector<Eigen::Matrix3Xd> training_surfaces;
    for (const TrainingPose& pose : model.poses) training_surfaces.push_back(pose.surface);
    std::ostringstream note;
    for (const HeldOutOverlap& overlap :
         FindHeldOutOverlaps(model.neutral.vertices, training_surfaces, test_surfaces,
                             options.error_vertices)) {
      note << "held-out pose '" << test_names[overlap.test] << "' is within "
           << overlap.distance << " of the training pose '"
           << model.poses[overlap.training].name << "' (it moves " << overlap.motion
           << " from the neutral): it is not held out. ";
    }
    overlap_note = note.str();
    if (!overlap_note.empty()) log << "warning: " << overlap_note << "\n";
  }
  // The physics fits of the held-out poses first: the part shared among ranks.
  WallTimer timer;
  std::vector<LatentFitResult> fits;
  std::vector<double> fit_seconds;
  if (!FitHeldOutPoses(model, options.fit, options.training_pose_starts, test_names,
                       test_surfaces, communicator, &fits, &fit_seconds, error)) {
    return false;
  }
  if (!test_names.empty()) {
    log << "held-out poses: " << test_names.size() << " physics fits in "
        << FormatDuration(timer.Seconds())
        << (distributed ? " over " + communicator->Description() : std::string()) << "\n";
  }
  if (!root) return true;

  // The baselines, trained on the same poses with the same latent size.
  std::vector<Eigen::Matrix3Xd> train_surfaces;
  for (const TrainingPose& pose : model.poses) train_surfaces.push_back(pose.surface);
  timer.Reset();
  const SurfacePca pca(train_surfaces, model.latent_dim());
  const SurfacePca pca_neutral(train_surfaces, model.latent_dim(), &model.neutral.vertices);
  SurfaceAutoencoderOptions ae_options = options.autoencoder;
  ae_options.latent_dim = model.latent_dim();
  ae_options.hidden_dims = options.autoencoder_hidden_dims ? *options.autoencoder_hidden_dims
                                                         : model.decoder->spec().hidden_dims;
  ae_options.activation = model.decoder->spec().activation;
  ae_options.anchored = model.decoder->spec().anchored;
  ae_options.linear_skip =
      options.autoencoder_linear_skip.value_or(model.decoder->spec().linear_skip);
  SurfaceAutoencoder autoencoder;
  if (!autoencoder.Train(model.neutral.vertices, train_surfaces, ae_options, log, error)) {
    *error = "the auto-encoder baseline: " + *error;
    return false;
  }
  log << "baselines: PCA with " << pca.num_components() << " components; auto-encoder trained in "
      << FormatDuration(timer.Seconds()) << " (rms " << autoencoder.report().rms_error << ")\n";

  std::vector<EvaluationRow> rows;
  const std::vector<int>& measured = options.error_vertices;
  LatentFitter fitter(model, options.fit);
  // Training poses.
  // BLAS threads for this model's factor size (util/blas.h).
  const ScopedBlasThreads blas(BlasThreadsForFactor(fitter.FactorNonzeros(), BlasThreads()));
  std::vector<Eigen::Matrix3Xd> trained_states(model.num_poses());
  // Per training pose the budget's per-vertex errors: floor, after pre-training,
  // trained (NaN where not measured), for the report's pictures.
  Eigen::MatrixXd training_errors =
      Eigen::MatrixXd::Constant(ns, 3 * model.num_poses(), std::numeric_limits<double>::quiet_NaN());
  for (int p = 0; p < model.num_poses(); ++p) {
    const Eigen::Matrix3Xd& truth = model.poses[p].surface;
    fitter.set_bone_transforms(TrainingPoseBones(model, p));
    // From the equilibrium training left for this pose (the energy is not convex: from
    // rest a large pose such as jawOpen may crawl or reach another branch).
    fitter.StartFromTrainingPose(p);
    Eigen::Matrix3Xd surface;
    if (!fitter.Simulate(model.latents.col(p), &trained_states[p], &surface, error)) {
      *error = "training pose '" + model.poses[p].name + "': " + *error;
      return false;
    }
    rows.push_back(Summarize("train", model.poses[p].name, kNeutral,
                             VertexErrors(model.neutral.vertices, truth), measured));
    training_errors.col(3 * p + 2) = VertexErrors(surface, truth);
    rows.push_back(Summarize("train", model.poses[p].name, "physics",
                             training_errors.col(3 * p + 2), measured));
    rows.push_back(Summarize("train", model.poses[p].name, "autoencoder",
                             VertexErrors(autoencoder.Decode(autoencoder.training_latents().col(p)), truth),
                             measured));
    rows.push_back(Summarize("train", model.poses[p].name, "pca",
                             VertexErrors(pca.Decode(pca.Encode(truth)), truth), measured));
    rows.push_back(Summarize("train", model.poses[p].name, "pca_neutral",
                             VertexErrors(pca_neutral.Decode(pca_neutral.Encode(truth)), truth),
                             measured));
  }
  // The training poses' error budget: (a) the volumetric targets simulated, (b) the
  // record of pre-training; (c) is the physics row above.
  PoseSimulationOptions budget_simulation;
  budget_simulation.solver = options.fit.solver;
  budget_simulation.num_threads = options.num_threads;
  bool have_pretrain = false;
  int floor_failures = 0;
  if (options.error_budget) {
    timer.Reset();
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
        SimulateActuations(model, targets, bones, starts, budget_simulation);
    for (size_t k = 0; k < floors.size(); ++k) {
      const int p = with_target[k];
      if (!floors[k].converged) {
        ++floor_failures;
        log << "  training pose '" << model.poses[p].name
            << "': its volumetric target's equilibrium did not converge (floor left out): "
            << floors[k].message << "\n";
        continue;
      }
      training_errors.col(3 * p) = VertexErrors(floors[k].surface, model.poses[p].surface);
      rows.push_back(Summarize("train", model.poses[p].name, "floor", training_errors.col(3 * p),
                               measured));
    }
    PretrainSurfaceErrors pretrain;
    std::string read_error;
    have_pretrain = ReadPretrainSurfaceErrors(options.model, model, &pretrain, &read_error);
    if (!read_error.empty()) {
      log << "  the pre-training record is unusable (stage (b) left out): " << read_error << "\n";
    }
    for (int p = 0; have_pretrain && p < model.num_poses(); ++p) {
      if (!pretrain.converged[p]) continue;  // no equilibrium: no error to report
      training_errors.col(3 * p + 1) = pretrain.distances.col(p);
      rows.push_back(Summarize("train", model.poses[p].name, "pretrain",
                               Eigen::VectorXd(pretrain.distances.col(p)), measured));
    }
    log << "error budget: " << targets.size() << " volumetric targets simulated in "
        << FormatDuration(timer.Seconds()) << "; surface error after pre-training "
        << (have_pretrain ? "from pretrain/surface_errors.*"
                          : "not recorded in the model (pre-trained without --pretrain_simulate "
                            "or by an older version)")
        << "\n";
  }

  // Held-out poses: fitted.
  std::vector<int> all(ns);
  for (int i = 0; i < ns; ++i) all[i] = i;
  struct HeldOut {
    // physics, autoencoder, pca, pca_neutral, floor (if made)
    Eigen::Matrix3Xd surfaces[5];
    Eigen::VectorXd errors[5];
    LatentFitResult fit;
    std::string ae_start;  // where the auto-encoder's latent fit started
  };
  std::vector<HeldOut> held_out(test_names.size());
  for (size_t t = 0; t < test_names.size(); ++t) {
    WallTimer pose_timer;
    const Eigen::Matrix3Xd& truth = test_surfaces[t];
    HeldOut& h = held_out[t];
    h.fit = fits[t];
    Eigen::VectorXd ae_latent;
    double ae_rms = 0;
    const Eigen::VectorXd ae_start = AutoencoderStart(autoencoder, model, truth,
                                                      options.training_pose_starts, &h.ae_start);
    if (!autoencoder.FitLatent(all, truth, ae_start, &ae_latent, &ae_rms)) {
      *error = "held-out pose '" + test_names[t] + "': the auto-encoder's latent fit failed";
      return false;
    }
    rows.push_back(Summarize("test", test_names[t], kNeutral,
                             VertexErrors(model.neutral.vertices, truth), measured));
    h.surfaces[0] = h.fit.surface;
    h.surfaces[1] = autoencoder.Decode(ae_latent);
    h.surfaces[2] = pca.Decode(pca.Encode(truth));
    h.surfaces[3] = pca_neutral.Decode(pca_neutral.Encode(truth));
    for (int m = 0; m < 4; ++m) {
      h.errors[m] = VertexErrors(h.surfaces[m], truth);
      rows.push_back(Summarize("test", test_names[t], kMethods[m], h.errors[m], measured));
    }
    log << "  " << test_names[t] << ": fitted in "
        << FormatDuration(fit_seconds[t] + pose_timer.Seconds())
        << " (physics " << h.fit.iterations << " iterations from " << h.fit.start
        << ", auto-encoder from " << h.ae_start << "), mean error: neutral "
        << rows[rows.size() - 5].mean << ", physics "
        << rows[rows.size() - 4].mean << ", autoencoder " << rows[rows.size() - 3].mean << ", PCA "
        << rows[rows.size() - 2].mean << ", PCA about the neutral " << rows.back().mean << "\n";
  }
  // The held-out poses' floor: their own volumetric targets (prepare's embedded
  // simulation, bones where the physics fit put them), simulated.
  bool have_held_out_floor = false;
  if (options.error_budget && !test_names.empty()) {
    timer.Reset();
    ActiveModel held = model;
    held.poses.clear();
    held.states.clear();
    for (Bone& bone : held.bones) bone.pose_transforms.clear();
    for (size_t t = 0; t < test_names.size(); ++t) {
      TrainingPose pose;
      pose.name = test_names[t];
      pose.surface = test_surfaces[t];
      held.poses.push_back(pose);
      for (size_t b = 0; b < held.bones.size(); ++b) {
        held.bones[b].pose_transforms.push_back(held_out[t].fit.bones[b]);
      }
    }
    std::ostringstream target_log;
    VolumetricTargetOptions target_options = options.held_out_targets;
    target_options.num_threads = options.num_threads;
    std::string target_error;
    if (!MakeVolumetricTargets(target_options, &held, target_log, &target_error)) {
      log << "  the held-out poses' volumetric targets failed (their floor is left out): "
          << target_error << "\n";
    } else {
      std::vector<ActuationMatrix> targets;
      std::vector<std::vector<RigidTransform>> bones;
      std::vector<Eigen::Matrix3Xd> starts;
      for (size_t t = 0; t < test_names.size(); ++t) {
        targets.push_back(held.poses[t].target);
        bones.push_back(held_out[t].fit.bones);
        starts.push_back(held_out[t].fit.state);
      }
      const std::vector<SimulatedPose> floors =
          SimulateActuations(model, targets, bones, starts, budget_simulation);
      have_held_out_floor = true;
      for (size_t t = 0; t < test_names.size(); ++t) {
        if (!floors[t].converged) {
          ++floor_failures;
          log << "  held-out pose '" << test_names[t]
              << "': its volumetric target's equilibrium did not converge (floor left out): "
              << floors[t].message << "\n";
          continue;
        }
        held_out[t].surfaces[4] = floors[t].surface;
        held_out[t].errors[4] = VertexErrors(floors[t].surface, test_surfaces[t]);
        rows.push_back(Summarize("test", test_names[t], "floor", held_out[t].errors[4], measured));
      }
      log << "error budget: the held-out poses' volumetric targets made and simulated in "
          << FormatDuration(timer.Seconds()) << "\n";
    }
  }
  if (options.write_fields && options.error_budget) {
    std::filesystem::create_directories(out + "/budget", code);
    if (code || !WriteMatrixFile(out + "/budget/training_errors.bin", training_errors, error)) {
      if (code) *error = out + "/budget: cannot create the folder (" + code.message() + ")";
      return false;
    }
  }
  if (options.write_fields) {
    const char* const kFieldMethods[5] = {"physics", "autoencoder", "pca", "pca_neutral", "floor"};
    for (size_t t = 0; t < test_names.size(); ++t) {
      const HeldOut& h = held_out[t];
      // One colour scale for the methods of a pose: the 95th percentile of all their
      // vertex errors, so that the fields compare by eye.
      std::vector<double> pooled;
      for (const Eigen::VectorXd& e : h.errors) pooled.insert(pooled.end(), e.data(), e.data() + e.size());
      const double color_max = PercentileColorMax(std::move(pooled));
      SurfaceMesh surface = model.neutral;
      surface.vertices = test_surfaces[t];
      if (!WriteObj(out + "/fitted/" + test_names[t] + "_target.obj", surface, error)) return false;
      for (int m = 0; m < 5; ++m) {
        if (h.surfaces[m].cols() == 0) continue;
        surface.vertices = h.surfaces[m];
        const std::string stem = test_names[t] + "_" + kFieldMethods[m];
        const std::vector<double> values(h.errors[m].data(), h.errors[m].data() + h.errors[m].size());
        if (!WriteObj(out + "/fitted/" + stem + ".obj", surface, error) ||
            !WritePlyWithScalar(out + "/fields/" + stem + ".ply", surface, values, color_max, error)) {
          return false;
        }
      }
    }
  }

  // Tables.
  std::ostringstream md;
  md << "# Evaluation of " << options.model << "\n\n"
     << "Vertex distances between each method's surface and the pose (model units), over "
     << num_error_vertices << " surface vertices. **neutral**: the rest surface itself (no motion), for reference. "
     << "Latent size " << model.latent_dim() << " for every method: "
     << "**physics** (this model: training latents, or latent and bone motion fitted to the "
     << "held-out pose through the simulator), **autoencoder** (surface-only decoder with "
     << LayoutNote(model.decoder->spec().hidden_dims, ae_options.hidden_dims)
     << (model.decoder->spec().anchored ? " and the same anchoring" : "")
     << SkipNote(model.decoder->spec().linear_skip, ae_options.linear_skip)
     << ", trained on the same poses, latent fitted), **PCA** (linear, "
     << pca.num_components() << " components about the training poses' mean, projection), "
     << "**PCA (neutral)** (linear, " << pca_neutral.num_components()
     << " components of the displacements from the neutral, uncentered: its zero is the "
     << "neutral, like an anchored decoder's zero latent).\n\n";
  const SurfaceAutoencoderReport& ae = autoencoder.report();
  md << "The auto-encoder trained " << ae.iterations << " L-BFGS iterations"
     << (ae_options.lbfgs_scaling ? " with scaled steps" : "") << " from seed "
     << ae_options.seed << ", loss " << ae.initial_loss
     << " -> " << ae.final_loss << " (" << ae.termination << ").\n\n";
  if (!overlap_note.empty()) md << "**Warning:** " << overlap_note << "\n\n";
  if (!test_names.empty()) {
    md << "Held-out latent fits start, for the physics model and the auto-encoder alike, from "
       << (options.training_pose_starts
               ? "the best of the mean training latent and each training pose's latent (and, for "
                 "the physics model, its bone motions and equilibrium) by the fit's own objective"
               : "the mean training latent (the physics model: bones at rest, from the rest shape)")
       << ":";
    for (size_t t = 0; t < test_names.size(); ++t) {
      md << (t ? "; " : " ") << test_names[t] << " from " << held_out[t].fit.start << " / "
         << held_out[t].ae_start;
    }
    md << ".\n\n";
  }
  const std::string train_table = MarkdownTable(rows, "train");
  const std::string test_table = MarkdownTable(rows, "test");
  md << "## Training poses\n\n" << train_table << "\n";
  if (!test_table.empty()) md << "## Held-out poses\n\n" << test_table << "\n";
  std::string budget;
  if (options.error_budget) {
    std::ostringstream b;
    b << "## Error budget\n\n"
      << "Where the physics model's error comes from (mean vertex error over the same "
      << num_error_vertices << " vertices). **(a) floor**: the pose's own volumetric target "
      << "(prepare's embedded simulation of the pose) simulated: what a perfect decoder could "
      << "reach on this simulation mesh and embedding. **(b) after pre-training**: the "
      << "pre-trained decoder's actuation of the pose's latent, simulated (pre-training fits the "
      << "targets, not the surfaces). **(c) trained**: the end-to-end trained model simulated "
      << "(the physics column above). (c) - (a) is what the decoder and its latent space still "
      << "miss; (b) - (c) what end-to-end training recovered.\n\n"
      << BudgetTable(rows, "train",
                     {{kNeutral, "neutral"}, {"floor", "(a) floor"},
                      {"pretrain", "(b) after pre-training"}, {"physics", "(c) trained"}});
    if (!have_pretrain) {
      b << "\n(b) is not recorded in this model: it is measured when pre-training ends "
        << "(`--pretrain_simulate`, pretrain/surface_errors.* in the model directory).\n";
    }
    if (!test_names.empty()) {
      b << "\nHeld-out poses: **floor**: the pose's own volumetric target, made by prepare's "
        << "embedded simulation with the bones where the physics fit put them, simulated; "
        << "**physics fit**: latent and bones fitted through the simulator. physics - floor is "
        << "what the learned latent space misses of this pose.\n\n"
        << BudgetTable(rows, "test",
                       {{kNeutral, "neutral"}, {"floor", "floor"}, {"physics", "physics fit"},
                        {"autoencoder", "autoencoder"}, {"pca", "PCA"},
                        {"pca_neutral", "PCA (neutral)"}});
      if (!have_held_out_floor) b << "\n(The held-out floor could not be made; see the log.)\n";
    }
    if (floor_failures > 0) {
      b << "\n" << floor_failures << " floor equilibria did not converge and are left out "
        << "(n/a).\n";
    }
    budget = b.str();
    md << budget << "\n";
  }
  std::string csv = "split,pose,method,mean,rms,max\n";
  for (const EvaluationRow& r : rows) {
    char line[256];
    std::snprintf(line, sizeof(line), "%s,%s,%s,%.17g,%.17g,%.17g\n", r.split.c_str(),
                  r.pose.c_str(), r.method.c_str(), r.mean, r.rms, r.max);
    csv += line;
  }
  if (!WriteFileAtomically(out + "/evaluation.md", md.str(), error) ||
      !WriteFileAtomically(out + "/evaluation.csv", csv, error)) {
    return false;
  }
  log << "\n" << train_table << "\n" << test_table << "\n" << budget << "\nwrote " << out
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
  return true;
}

}  // namespace aqs
