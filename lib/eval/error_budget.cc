#include "eval/error_budget.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include <glog/logging.h>

#include "equilibrium/rest_factor.h"
#include "geometry/embedding.h"
#include "physics/shape_target_model.h"
#include "util/atomic_file.h"
#include "util/blas.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/matrix_io.h"
#include "util/number_format.h"
#include "util/parallel_for.h"
#include "util/option_checks.h"

namespace aqs {

bool PoseSimulationOptions::Validate(std::string* error) const {
  std::string solver_error;
  const bool solver_ok = solver.Validate(&solver_error);
  return OptionChecks()
      .Nested("solver", solver_ok, solver_error)
      .ReachableTolerance("solver.relative_force_tolerance", solver.relative_force_tolerance)
      .IntInRange("num_threads", num_threads, 1, 1024)
      .Done(error);
}
namespace {

std::string BinaryPath(const std::string& dir) { return dir + "/pretrain/surface_errors.bin"; }
std::string TextPath(const std::string& dir) { return dir + "/pretrain/surface_errors.txt"; }

}  // namespace

Eigen::VectorXd VertexDistances(const Eigen::Matrix3Xd& a, const Eigen::Matrix3Xd& b) {
  CHECK_EQ(a.cols(), b.cols());
  return (a - b).colwise().norm().transpose();
}

DistanceSummary SummarizeDistances(const Eigen::VectorXd& distances,
                                   const std::vector<int>& vertices) {
  DistanceSummary s;
  double sum = 0, squares = 0;
  int n = 0;
  auto add = [&](double d) {
    sum += d;
    squares += d * d;
    s.max = std::max(s.max, d);
    ++n;
  };
  if (vertices.empty()) {
    for (Eigen::Index i = 0; i < distances.size(); ++i) add(distances[i]);
  } else {
    for (int v : vertices) add(distances[v]);
  }
  if (n > 0) {
    s.mean = sum / n;
    s.rms = std::sqrt(squares / n);
  }
  return s;
}

std::vector<RigidTransform> TrainingPoseBones(const ActiveModel& model, int p) {
  std::vector<RigidTransform> bones;
  for (const Bone& bone : model.bones) bones.push_back(bone.pose_transforms[p]);
  return bones;
}

std::vector<ActuationMatrix> DecodeTrainingLatents(const ActiveModel& model) {
  CHECK(model.decoder != nullptr);
  std::vector<ActuationMatrix> actuations;
  DecoderWorkspace workspace;
  model.decoder->DecodeBatch(model.decoder_params.data(), model.latents, &actuations, &workspace);
  return actuations;
}

std::vector<SimulatedPose> SimulateActuations(
    const ActiveModel& model, const std::vector<ActuationMatrix>& actuations,
    const std::vector<std::vector<RigidTransform>>& bone_transforms,
    const std::vector<Eigen::Matrix3Xd>& start_states, const PoseSimulationOptions& options) {
  const int count = static_cast<int>(actuations.size());
  CHECK_EQ(bone_transforms.size(), actuations.size());
  CHECK(start_states.empty() || start_states.size() == actuations.size());
  std::vector<SimulatedPose> results(count);
  if (count == 0) return results;
  const ShapeTargetModel physics(model.mesh, model.mu);
  QuasistaticSolverOptions solver_options = options.solver;
  solver_options.num_threads = 1;
  const int threads = std::max(1, std::min(options.num_threads, count));
  // One pose per thread, BLAS single-threaded meanwhile (as in training; threaded BLAS
  // called by every pose's factorization at once is slower than one thread).
  const ScopedBlasThreads blas(threads > 1 ? 1 : BlasThreads());
  std::vector<std::unique_ptr<QuasistaticSolver>> solvers(threads);
  std::vector<StoredStiffnessFactor> rest_factors(threads);
  ParallelFor(threads, 0, count, [&](int t, int k) {
    if (!solvers[t]) {
      solvers[t] = std::make_unique<QuasistaticSolver>(
          physics, ModelBoundaryConditions(model, RestBoneTransforms(model)), solver_options);
      rest_factors[t] = RestStiffnessFactor(model.mesh.vertices, solvers[t].get());
    }
    QuasistaticSolver& solver = *solvers[t];
    // Every pose starts from the rest factor, not from the factor of the pose this thread
    // solved before: the result depends on the pose alone, not on the thread count.
    StartFromFactor(rest_factors[t], &solver);
    solver.SetFixedPositions(ModelBoundaryConditions(model, bone_transforms[k]).positions);
    solver.actuation() = actuations[k];
    solver.SetPositions(model.mesh.vertices);
    QuasistaticSolveReport report = solver.Solve();
    if (!report.converged && !start_states.empty() &&
        start_states[k].cols() == model.mesh.num_vertices()) {
      solver.SetPositions(start_states[k]);
      report = solver.Solve();
    }
    SimulatedPose& result = results[k];
    result.converged = report.converged;
    if (!report.converged) result.message = report.Summary();
    result.state = solver.positions();
    result.surface = EmbeddedPositions(model.embedding, model.mesh.tets, result.state);
  }, 1);
  return results;
}

bool WritePretrainSurfaceErrors(const std::string& model_directory, const ActiveModel& model,
                                const PretrainSurfaceErrors& errors, std::string* error) {
  CHECK_EQ(errors.distances.rows(), model.num_surface_vertices());
  CHECK_EQ(errors.distances.cols(), model.num_poses());
  CHECK_EQ(static_cast<int>(errors.converged.size()), model.num_poses());
  std::error_code code;
  std::filesystem::create_directories(model_directory + "/pretrain", code);
  if (code) {
    *error = model_directory + "/pretrain: cannot create the folder (" + code.message() + ")";
    return false;
  }
  std::string text =
      "# surface error after pre-training: the pre-trained latents decoded and simulated\n"
      "# (distances over all surface vertices, model units)\n"
      "# index name mean max converged\n";
  for (int p = 0; p < model.num_poses(); ++p) {
    const Eigen::VectorXd d = errors.distances.col(p);
    const DistanceSummary s = SummarizeDistances(d, {});
    char line[128];
    std::snprintf(line, sizeof(line), " %.17g %.17g %d\n", s.mean, s.max, errors.converged[p]);
    text += std::to_string(p) + " " + model.poses[p].name + line;
  }
  return WriteMatrixFile(BinaryPath(model_directory), errors.distances, error) &&
         WriteFileAtomically(TextPath(model_directory), text, error);
}

bool ReadPretrainSurfaceErrors(const std::string& model_directory, const ActiveModel& model,
                               PretrainSurfaceErrors* errors, std::string* error) {
  error->clear();
  const std::string text_path = TextPath(model_directory);
  if (!MayExist(text_path)) return false;
  PretrainSurfaceErrors read;
  if (!ReadMatrixFile(BinaryPath(model_directory), model.num_surface_vertices(), model.num_poses(),
                      &read.distances, error)) {
    return false;
  }
  // Distances are finite and >= 0 (a damaged file put NaN and -9e296 into the training
  // log and the evaluation's tables; the callers leave stage (b) out, saying why).
  for (Eigen::Index p = 0; p < read.distances.cols(); ++p) {
    for (Eigen::Index v = 0; v < read.distances.rows(); ++v) {
      const double d = read.distances(v, p);
      if (std::isfinite(d) && d >= 0) continue;
      *error = BinaryPath(model_directory) + ": the distance of surface vertex " +
               std::to_string(v) + " in pose " + std::to_string(p) + " is " + FormatDouble(d) +
               ", not a finite distance >= 0";
      return false;
    }
  }
  LineReader reader(text_path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  std::vector<std::string> tokens;
  int p = 0;
  while (reader.NextTokens(&tokens)) {
    int index = -1, converged = -1;
    double mean = 0.0, max = 0.0;  // checked only: the distances come from the binary file
    if (tokens.size() != 5 || !ParseInt(tokens[0], &index) || !ParseDouble(tokens[2], &mean) ||
        !ParseDouble(tokens[3], &max) || !ParseInt(tokens[4], &converged) ||
        (converged != 0 && converged != 1)) {
      *error = reader.Where(
          "expected 'index name mean max converged' (mean and max numbers, converged 0 or 1)");
      return false;
    }
    if (p >= model.num_poses() || index != p || tokens[1] != model.poses[p].name) {
      *error = reader.Where("pose " + tokens[0] + " '" + tokens[1] +
                            "' does not match the model's poses (" +
                            std::to_string(model.num_poses()) + ", in poses.txt's order)");
      return false;
    }
    read.converged.push_back(converged);
    ++p;
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (p != model.num_poses()) {
    *error = text_path + ": " + std::to_string(p) + " poses, the model has " +
             std::to_string(model.num_poses());
    return false;
  }
  *errors = std::move(read);
  return true;
}

std::string TrainingBudgetTable(const ActiveModel& model, const PretrainSurfaceErrors* pretrain,
                                const std::vector<Eigen::Matrix3Xd>& trained_surfaces) {
  const bool trained = !trained_surfaces.empty();
  CHECK(!trained || static_cast<int>(trained_surfaces.size()) == model.num_poses());
  std::string out;
  char line[256];
  std::snprintf(line, sizeof(line), "  %-24s %21s %21s %21s\n", "pose (mean / max)",
                "(a) embedding floor", pretrain ? "(b) after pretrain" : "(b) not recorded",
                trained ? "(c) trained" : "");
  out += line;
  double sums[3] = {0, 0, 0}, maxima[3] = {0, 0, 0};
  const int np = model.num_poses();
  bool pretrain_complete = true;  // every pose's stage (b) converged
  for (int p = 0; p < np; ++p) {
    const TrainingPose& pose = model.poses[p];
    std::snprintf(line, sizeof(line), "  %-24s %10.4g / %-8.4g", pose.name.c_str(),
                  pose.embedding_mean_error, pose.embedding_max_error);
    out += line;
    sums[0] += pose.embedding_mean_error;
    maxima[0] = std::max(maxima[0], pose.embedding_max_error);
    if (pretrain) {
      const DistanceSummary s = SummarizeDistances(pretrain->distances.col(p), {});
      std::snprintf(line, sizeof(line), " %10.4g / %-8.4g%s", s.mean, s.max,
                    pretrain->converged[p] ? "" : " (not converged)");
      out += line;
      sums[1] += s.mean;
      maxima[1] = std::max(maxima[1], s.max);
      pretrain_complete = pretrain_complete && pretrain->converged[p];
    } else {
      out += std::string(22, ' ');
    }
    if (trained) {
      const DistanceSummary s =
          SummarizeDistances(VertexDistances(trained_surfaces[p], pose.surface), {});
      std::snprintf(line, sizeof(line), " %10.4g / %-8.4g", s.mean, s.max);
      out += line;
      sums[2] += s.mean;
      maxima[2] = std::max(maxima[2], s.max);
    }
    out += "\n";
  }
  if (np > 0) {
    std::snprintf(line, sizeof(line), "  %-24s %10.4g / %-8.4g", "mean over poses (max)",
                  sums[0] / np, maxima[0]);
    out += line;
    for (int k = 1; k < 3; ++k) {
      if ((k == 1 && !pretrain) || (k == 2 && !trained)) {
        if (k == 1) out += std::string(22, ' ');
        continue;
      }
      if (k == 1 && !pretrain_complete) {
        // An unconverged pose's distances are those of wherever its solve stopped: no mean
        // over the poses (as evaluation.md's budget).
        std::snprintf(line, sizeof(line), " %21s", "n/a");
      } else {
        std::snprintf(line, sizeof(line), " %10.4g / %-8.4g", sums[k] / np, maxima[k]);
      }
      out += line;
    }
    out += "\n";
  }
  return out;
}

}  // namespace aqs
