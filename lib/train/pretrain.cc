#include "train/pretrain.h"

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>

#include <ceres/gradient_problem.h>
#include <ceres/gradient_problem_solver.h>
#include <ceres/iteration_callback.h>

#include "model/fit_prior.h"
#include "model/model_fingerprint.h"
#include "train/latent_init.h"
#include "train/lbfgs_restarts.h"
#include "train/solver_checkpoint.h"
#include "train/pretrain_objective.h"
#include "train/progress.h"
#include "util/atomic_file.h"
#include "util/fnv_hash.h"
#include "util/iteration_log.h"
#include "util/make_directory.h"
#include "util/number_format.h"
#include "util/option_checks.h"
#include "util/text_split.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

// L-BFGS (Ceres' GradientProblemSolver, rank kLbfgsRank): the history's two arrays per
// rank and about eight work vectors of the parameter count. Ceres' default 20: rank 10
// reaches the same pre-training loss in 0.72x to 0.76x the time, but the one demo
// trained from it fitted the held-out poses worse (docs/benchmarks.md, "Pre-training's
// L-BFGS rank"), so it is not used until that is measured over more runs.
constexpr int kLbfgsRank = 20;
constexpr double kLbfgsArrays = 2.0 * kLbfgsRank + 8.0;

// Whitened principal-component scores of the training surfaces' displacements from the
// neutral (latent_dim x poses; PretrainLatentStart::kSurfaces).
Eigen::MatrixXd SurfaceLatents(const ActiveModel& model, int latent_dim) {
  const Eigen::Index n3 = 3 * static_cast<Eigen::Index>(model.num_surface_vertices());
  Eigen::MatrixXd surfaces(n3, model.num_poses());
  for (int i = 0; i < model.num_poses(); ++i) {
    surfaces.col(i) = Eigen::Map<const Eigen::VectorXd>(model.poses[i].surface.data(), n3);
  }
  const Eigen::VectorXd neutral =
      Eigen::Map<const Eigen::VectorXd>(model.neutral.vertices.data(), n3);
  return WhitenedPcaScores(surfaces, Eigen::VectorXd::Ones(n3), latent_dim, &neutral);
}

// Ends Ceres' iterations successfully once max_seconds (> 0) have passed since its
// construction (or max_seconds less `spent`).
class TimeBudget final : public ceres::IterationCallback {
 public:
  TimeBudget(double max_seconds, double spent)
      : max_seconds_(max_seconds > 0.0 ? std::max(1e-9, max_seconds - spent) : 0.0) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary&) override {
    return max_seconds_ > 0.0 && timer_.Seconds() > max_seconds_
               ? ceres::SOLVER_TERMINATE_SUCCESSFULLY
               : ceres::SOLVER_CONTINUE;
  }

 private:
  double max_seconds_;
  WallTimer timer_;
};

// Appends one row per iteration, "iteration,loss,gradient_norm,seconds", to the CSV log
// at `path`, counting iterations and seconds after an earlier run's (`before`; its last
// row is the checkpoint's, so a resumed run's row 0 is not repeated).
class CsvLog final : public ceres::IterationCallback {
 public:
  // A row that cannot be appended is said once in `log`.
  CsvLog(std::string path, int iterations_before, double seconds_before, std::ostream& log)
      : path_(std::move(path)), iterations_(iterations_before), seconds_(seconds_before),
        log_(log) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (s.iteration == 0 && iterations_ > 0) return ceres::SOLVER_CONTINUE;
    std::string row = std::to_string(iterations_ + s.iteration);
    for (double value : {s.cost, s.gradient_norm, seconds_ + timer_.Seconds()}) {
      row += ",";
      AppendDouble(value, &row);
    }
    std::string error;
    if (!AppendLogRow(path_, row + "\n", &error) && !warned_) {
      log_ << "  warning: " << error << "; pre-training goes on\n";
      warned_ = true;
    }
    return ceres::SOLVER_CONTINUE;
  }

 private:
  std::string path_;
  int iterations_;
  double seconds_;
  std::ostream& log_;
  bool warned_ = false;
  WallTimer timer_;
};

// With options.checkpoint_directory: *start gets this pre-training's key and, with
// options.resume, the checkpoint there that belongs to it (its point into *parameters);
// the CSV log at log_path is cut back to that checkpoint. A run that does not resume the
// checkpoint there removes it first (else, stopped before its own first checkpoint, it
// would leave the old one for the next run to resume, beside a log of this run), or
// with options.kept_checkpoints_directory keeps it and its log there and, with resume,
// takes back one kept for its own key (a mistyped flag no longer costs the hours the
// checkpoint held). Says in `log` what it resumed, or why not, and where an earlier
// checkpoint went. False with *error if the log or the folder cannot be
// written.
bool OpenCheckpoints(const PretrainOptions& options, const ActiveModel& model,
                     const std::string& log_path, Eigen::VectorXd* parameters,
                     SolverCheckpoint* start, std::ostream& log, std::string* error) {
  const std::string& directory = options.checkpoint_directory;
  start->key = PretrainCheckpointKey(options, model);
  std::string why_not;
  SolverCheckpoint found;
  bool resumed = false;
  // Resumes `found`, read from `where`.
  const auto resume = [&](const std::string& where) {
    *start = std::move(found);
    *parameters = start->parameters;
    resumed = true;
    log << "pretrain: resuming after iteration " << start->iterations << " ("
        << FormatDuration(start->seconds) << " spent, loss " << start->loss << ") from the "
        << where << "\n";
  };
  if (!options.resume) {
    log << "pretrain: starting anew (an earlier run's checkpoint in " << directory
        << " is not resumed)\n";
  } else if (ReadSolverCheckpoint(directory, start->key, static_cast<int>(parameters->size()),
                                  &found, &why_not)) {
    resume("checkpoint in " + directory);
  } else if (!why_not.empty()) {
    log << "pretrain: not resuming the checkpoint in " << directory << ": " << why_not
        << "; starting anew\n";
  }
  if (!MakeDirectory(directory, error)) return false;
  const std::string& kept = options.kept_checkpoints_directory;
  const std::vector<std::string> also = {std::filesystem::path(log_path).filename()};
  bool removed = false;
  if (resumed && !kept.empty() && !RemoveKeptCheckpoint(kept, start->key, &removed, error)) {
    return false;
  }
  if (removed) {
    log << "pretrain: removed the copy of this checkpoint kept in " << kept
        << " (left by a run stopped while it moved the checkpoint there)\n";
  }
  if (!resumed && kept.empty() && !RemoveSolverCheckpoint(directory, error)) return false;
  if (!resumed && !kept.empty()) {
    bool moved = false, restored = false;
    if (!MoveSolverCheckpointAside(directory, kept, also, &moved, error)) return false;
    if (moved) {
      log << "pretrain: the earlier run's checkpoint and log are kept in " << kept
          << " (a pre-training with its options takes them back)\n";
    }
    if (options.resume &&
        !RestoreKeptCheckpoint(directory, kept, start->key, also, &restored, error)) {
      return false;
    }
    if (restored &&
        ReadSolverCheckpoint(directory, start->key, static_cast<int>(parameters->size()),
                             &found, &why_not)) {
      resume("checkpoint of these options kept in " + kept);
    } else if (restored) {
      log << "pretrain: the checkpoint of these options kept in " << kept
          << " is not resumed: " << why_not << "; starting anew\n";
      if (!RemoveSolverCheckpoint(directory, error)) return false;
    }
  }
  // A run of an older version kept its log in kPretrainLogName.
  const std::string old_log = directory + "/" + kPretrainLogName;
  std::error_code code;
  if (resumed && !std::filesystem::exists(log_path, code) &&
      std::filesystem::exists(old_log, code) &&
      !WriteFileAtomically(log_path, ReadWholeFile(old_log), error)) {
    return false;
  }
  int last_row = -1;
  if (!PrepareIterationLog(log_path, kPretrainLogHeader, start->iterations, &last_row, error)) {
    return false;
  }
  if (start->iterations > 0 && last_row < start->iterations) {
    log << "pretrain: warning: " << log_path << " has rows up to " << last_row
        << ", the checkpoint is of iteration " << start->iterations
        << ": rows are missing (the log was cut or replaced)\n";
  }
  return true;
}

}  // namespace

CheckpointKey PretrainCheckpointKey(const PretrainOptions& options, const ActiveModel& model) {
  uint64_t hash = kFnvOffsetBasis;
  for (const TrainingPose& pose : model.poses) {
    const Eigen::Index size = pose.target.size();
    hash = Fnv1a(&size, sizeof(size), hash);
    hash = Fnv1a(pose.target.data(), sizeof(double) * size, hash);
  }
  const DecoderSpec& spec = options.spec;
  std::ostringstream text;
  text << "latent_dim=" << spec.latent_dim << " hidden=" << JoinInts(spec.hidden_dims, "none")
       << " activation=" << ActivationName(spec.activation)
       << " output_scale=" << FormatDouble(spec.output_scale) << " anchored=" << spec.anchored
       << " linear_skip=" << spec.linear_skip
       << " node_spacing=" << FormatDouble(options.field.node_spacing)
       << " node_spacing_factor=" << FormatDouble(options.field.node_spacing_factor)
       << " per_element=" << options.field.per_element
       << " latent_start=" << PretrainLatentStartName(options.latent_start)
       << " latent_regularization=" << FormatDouble(options.latent_regularization)
       << " decoder_regularization=" << FormatDouble(options.decoder_regularization)
       << " seed=" << options.seed;
  return {{"model", FingerprintText(ModelFingerprint(model))},
          {"targets", FingerprintText(hash)},
          {"options", text.str()}};
}

const char* PretrainLatentStartName(PretrainLatentStart start) {
  return start == PretrainLatentStart::kSurfaces ? "surfaces" : "targets";
}

bool PretrainLatentStartFromName(const std::string& name, PretrainLatentStart* start) {
  for (PretrainLatentStart s : {PretrainLatentStart::kTargets, PretrainLatentStart::kSurfaces}) {
    if (name == PretrainLatentStartName(s)) {
      *start = s;
      return true;
    }
  }
  return false;
}

bool PretrainOptions::Validate(std::string* error) const {
  std::string spec_error, field_error;
  const bool spec_ok = spec.Validate(&spec_error);
  const bool field_ok = field.Validate(&field_error);
  return OptionChecks()
      .Nested("spec", spec_ok, spec_error)
      .Nested("field", field_ok, field_error)
      .InRange("latent_regularization", latent_regularization, 0.0, kMaxRegularization)
      .InRange("decoder_regularization", decoder_regularization, 0.0, kMaxRegularization)
      .IntAtLeast("max_iterations", max_iterations, 0)
      .IntAtLeast("max_restarts", max_restarts, 0)
      .NonNegative("max_seconds", max_seconds)
      .NonNegative("checkpoint_seconds", checkpoint_seconds)
      .IntAtLeast("log_every", log_every, 0)
      .Positive("max_memory_bytes", max_memory_bytes)
      .Done(error);
}

bool PretrainMemoryBytes(const PretrainOptions& options, const ActiveModel& model, double* bytes,
                         std::string* details, std::string* error) {
  if (model.mesh.num_tets() == 0) {
    *error = "the model's mesh has no elements";
    return false;
  }
  double nodes = 0.0;
  std::string field_error;
  if (!PlanGridActuationField(model.mesh, options.field, &nodes, &field_error)) {
    *error = "field." + field_error;
    return false;
  }
  const double elements = model.mesh.num_tets();
  const double poses = model.num_poses();
  double parameters = 0.0;
  const DecoderMemory decoder = DecoderMemoryBytes(options.spec, elements, nodes,
                                                   options.field.per_element, poses, &parameters);
  const double unknowns = parameters + static_cast<double>(options.spec.latent_dim) * poses;
  const double lbfgs = sizeof(double) * kLbfgsArrays * unknowns;
  const double targets = 4.0 * sizeof(double) * 6.0 * elements * poses;
  *bytes = decoder.total + lbfgs + targets;
  if (details != nullptr) {
    std::ostringstream out;
    out.precision(3);
    out << parameters << " decoder parameters for " << nodes << " control nodes at most, "
        << poses << " poses x latent " << options.spec.latent_dim << ": L-BFGS "
        << FormatBytes(lbfgs) << ", decoder and batch " << FormatBytes(decoder.total)
        << ", targets " << FormatBytes(targets);
    *details = out.str();
  }
  if (!(parameters < std::numeric_limits<int>::max())) {
    std::ostringstream out;
    out.precision(3);
    out << "spec.hidden_dims: the decoder would have " << parameters << " parameters ("
        << nodes << " control nodes at most), more than " << std::numeric_limits<int>::max()
        << ", the most it can have";
    *error = out.str();
    return false;
  }
  return true;
}

bool Pretrain(const PretrainOptions& options, ActiveModel* model, PretrainReport* report,
              std::ostream& log, std::string* error) {
  WallTimer timer;
  if (!options.Validate(error)) return false;
  {
    double bytes = 0.0;
    std::string details;
    if (!PretrainMemoryBytes(options, *model, &bytes, &details, error) ||
        !CheckMemoryEstimate(bytes, options.max_memory_bytes, "pre-training", details, error)) {
      return false;
    }
  }
  const int p = model->num_poses();
  if (p == 0) {
    *error = "the model has no training poses";
    return false;
  }
  std::vector<ActuationMatrix> targets;
  for (const TrainingPose& pose : model->poses) {
    if (pose.target.cols() != model->mesh.num_tets()) {
      *error = "pose '" + pose.name + "' has no volumetric target (run aqs_prepare)";
      return false;
    }
    targets.push_back(pose.target);
  }
  const int m = model->mesh.num_tets();
  Eigen::VectorXd volume(m);
  for (int e = 0; e < m; ++e) {
    volume[e] = std::abs(SignedTetVolume(model->mesh, model->mesh.vertices, e));
  }
  const Eigen::VectorXd weights = volume / volume.sum();

  GridActuationField field(model->mesh, options.field);
  auto decoder = std::make_shared<ActuationDecoder>(options.spec, std::move(field));
  const int np = decoder->num_parameters();
  const int d = decoder->latent_dim();
  Eigen::VectorXd parameters(np + d * p);
  decoder->InitializeParameters(options.seed, parameters.data());
  const bool hold_latents = options.latent_start == PretrainLatentStart::kSurfaces;
  Eigen::Map<Eigen::MatrixXd> latents(parameters.data() + np, d, p);
  if (hold_latents) {
    latents = SurfaceLatents(*model, d);
  } else {  // whitened principal components of the (volume-weighted) targets
    Eigen::MatrixXd samples(6 * static_cast<Eigen::Index>(m), p);
    for (int i = 0; i < p; ++i) {
      samples.col(i) = Eigen::Map<const Eigen::VectorXd>(targets[i].data(), targets[i].size());
    }
    Eigen::VectorXd row_weights(6 * static_cast<Eigen::Index>(m));
    for (int e = 0; e < m; ++e) {
      row_weights.segment<6>(6 * e) = weights[e] * ActuationEntryWeights();
    }
    latents = WhitenedPcaScores(samples, row_weights, d);
  }
  log << "pretrain: " << np << " decoder parameters (" << decoder->num_nodes()
      << " control nodes), " << p << " poses x latent " << d << "; latents "
      << (hold_latents ? "held at the surfaces' principal components"
                       : "from the targets' principal components")
      << "\n";

  // A checkpoint of an earlier run of this pre-training: its point and its budget spent.
  SolverCheckpoint start;
  const bool checkpoints = !options.checkpoint_directory.empty();
  const std::string log_path =
      checkpoints ? options.checkpoint_directory + "/" + kPretrainRunLogName : std::string();
  if (checkpoints && !OpenCheckpoints(options, *model, log_path, &parameters, &start, log,
                                      error)) {
    return false;
  }
  report->iterations_before = start.iterations;
  auto* objective = new PretrainObjective(*decoder, targets, weights,
                                         options.latent_regularization,
                                         options.decoder_regularization);
  objective->HoldLatents(hold_latents);
  report->initial_loss = objective->Loss(parameters.data(), nullptr, nullptr);
  if (start.iterations > 0 && !SameLoss(report->initial_loss, start.loss)) {
    // Its numbers were read as finite, but they are not the point it recorded: damaged.
    *error = "the checkpoint in " + options.checkpoint_directory + " resumed gives a loss of " +
             FormatDouble(report->initial_loss) + " where it recorded " +
             FormatDouble(start.loss) + ": it is damaged; pre-train anew without resuming it " +
             "(resume off) or remove it";
    delete objective;
    return false;
  }
  if (!std::isfinite(report->initial_loss)) {
    *error = "the pre-training loss is not finite at the start (" +
             std::to_string(report->initial_loss) +
             "): the decoder's output scale (spec.output_scale) or the latent regularization "
             "(latent_regularization) is far too large?";
    delete objective;
    return false;
  }
  ceres::GradientProblem problem(objective);  // takes ownership
  ceres::GradientProblemSolver::Options solver_options;
  solver_options.line_search_direction_type = ceres::LBFGS;
  solver_options.max_lbfgs_rank = kLbfgsRank;
  solver_options.function_tolerance = 1e-12;
  solver_options.gradient_tolerance = 1e-12;
  solver_options.parameter_tolerance = 1e-14;
  solver_options.logging_type = ceres::SILENT;
  // Restarts after a stall (train/lbfgs_restarts.h) continue the iteration numbers of
  // the progress lines, the CSV log and the checkpoints.
  LbfgsRestartOptions restart_options;
  restart_options.max_iterations = options.max_iterations;
  restart_options.max_restarts = options.max_restarts;
  ProgressLogger progress("pretrain", options.log_every, options.max_iterations, log,
                          start.iterations,
                          options.max_seconds > 0
                              ? std::max(0.0, options.max_seconds - start.seconds)
                              : -1.0);
  restart_options.callbacks.push_back(&progress);
  TimeBudget budget(options.max_seconds, start.seconds);
  // The checkpoints read the point reached from `parameters` (which RunLbfgsWithRestarts
  // keeps at the last accepted point).
  SolverCheckpointWriter writer(options.checkpoint_directory, start,
                                options.checkpoint_seconds, parameters.data(),
                                static_cast<int>(parameters.size()));
  CsvLog csv_log(log_path, start.iterations, start.seconds, log);
  if (checkpoints) {
    // The row of an iteration goes before its checkpoint: a kill in between leaves a row
    // more than the checkpoint, which the next run drops.
    restart_options.callbacks.push_back(&csv_log);
    restart_options.callbacks.push_back(&writer);
  }
  // The budget last: the iteration at which it stops the run has its log row, as the
  // final checkpoint written after the run has that iteration.
  restart_options.callbacks.push_back(&budget);
  const bool spent = options.max_seconds > 0.0 && start.seconds >= options.max_seconds;
  LbfgsRunReport run;
  run.iterations = start.iterations;
  if (!spent && start.iterations < options.max_iterations) {
    run = RunLbfgsWithRestarts(solver_options, problem, restart_options, start.iterations,
                               parameters.data(), log);
  } else {
    run.termination = start.iterations > 0 ? "the checkpoint had used the whole budget"
                                           : "no iterations in the budget";
  }
  const int run_iterations = run.iterations - start.iterations;
  if (!writer.error().empty()) {
    *error = "pre-training stopped: its checkpoint could not be written: " + writer.error();
    return false;
  }
  double mse = 0;
  report->final_loss = objective->Loss(parameters.data(), nullptr, &mse);
  if (!std::isfinite(report->final_loss) || !parameters.allFinite()) {
    *error = "pre-training ended with a non-finite loss or parameters (" +
             std::to_string(report->final_loss) + "; " + run.termination + ")";
    return false;
  }
  report->rms_actuation_error = std::sqrt(mse);
  report->iterations = start.iterations + run_iterations;
  if (checkpoints && run_iterations > 0 && !writer.Write(report->iterations, report->final_loss)) {
    *error = "pre-training's last checkpoint could not be written: " + writer.error();
    return false;
  }
  report->checkpoints = writer.checkpoints();
  report->restarts = run.restarts;
  report->stalled_without_restarts = run_iterations > 0 &&
                                     report->iterations < options.max_iterations &&
                                     (run.termination_type == ceres::CONVERGENCE ||
                                      run.termination_type == ceres::FAILURE) &&
                                     run.restarts >= options.max_restarts;
  report->termination = run.termination;
  report->seconds = timer.Seconds();
  log << "pretrain: " << report->iterations << " iterations";
  if (report->restarts > 0) {
    log << " (" << report->restarts << " L-BFGS restart" << (report->restarts > 1 ? "s" : "")
        << ")";
  }
  log << ", loss " << report->initial_loss << " -> " << report->final_loss
      << ", rms actuation error " << report->rms_actuation_error << " ("
      << FormatDuration(report->seconds) << "; " << report->termination << ")\n";
  model->decoder = decoder;
  model->decoder_params = parameters.head(np);
  model->latents = Eigen::Map<const Eigen::MatrixXd>(parameters.data() + np, d, p);
  model->states.clear();
  model->checkpoint = TrainingCheckpoint();  // a new decoder: no training done yet
  // The fits' prior belonged to the old latents (of another size, it failed the next
  // fitter's CHECK): none, so that fits learn it from these (and a save writes theirs).
  model->fit_prior = FitPrior();
  return true;
}

}  // namespace aqs
