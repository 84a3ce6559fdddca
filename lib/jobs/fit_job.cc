#include "jobs/fit_job.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include <Eigen/Geometry>

#include "eval/scan_error_split.h"
#include "fit/chosen_start_fit.h"
#include "geometry/points_near_model.h"
#include "geometry/vertex_normals.h"
#include "io/latent_io.h"
#include "jobs/deformed_output.h"
#include "jobs/model_pose.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "model/model_io.h"
#include "util/blas.h"
#include "util/file_extension.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/option_checks.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

FitJobResult Fail(const std::string& message) {
  FitJobResult result;
  result.status = JobStatus::kBadInput;
  result.message = message;
  return result;
}

std::vector<std::string> BoneNames(const ActiveModel& model) {
  std::vector<std::string> names;
  for (const Bone& bone : model.bones) names.push_back(bone.name);
  return names;
}

// The fit's outputs (the surface, and optionally the latent and the volume).
bool WriteFitOutputs(const FitJobOptions& options, const ActiveModel& model,
                     const LatentFitResult& fit, const std::string& note, std::ostream& log,
                     std::string* error) {
  SurfaceMesh surface = model.neutral;
  surface.vertices = fit.surface;
  if (!WriteObj(options.output, surface, error)) return false;
  log << "wrote " << options.output << note << "\n";
  if (!options.latent_output.empty()) {
    if (!WriteLatentFile(options.latent_output, fit.latent, BoneNames(model), fit.bones,
                         "fitted to " + options.target + note, LatentFileModelOf(model),
                         error)) {
      return false;
    }
    log << "wrote " << options.latent_output << note << "\n";
  }
  if (!options.output_volume.empty()) {
    ActuationMatrix a;
    DecoderWorkspace workspace;
    model.decoder->Decode(model.decoder_params.data(), fit.latent, &a, &workspace);
    const std::vector<VtuField> point_fields = {MakeVtuField("displacement", fit.state - model.mesh.vertices)};
    const std::vector<VtuField> cell_fields = {MakeVtuField("actuation", a)};
    if (!WriteDeformedMesh(options.output_volume, model.mesh, fit.state, point_fields, cell_fields,
                           error)) {
      return false;
    }
    log << "wrote " << options.output_volume << note << "\n";
  }
  if (!options.output_uncertainty.empty() && fit.surface_std.size() == fit.surface.cols()) {
    // Coloured up to the 95th percentile over the surface (a few large values at the
    // back of the head would wash out the face).
    const std::vector<double> values(fit.surface_std.data(),
                                     fit.surface_std.data() + fit.surface_std.size());
    if (!WritePlyWithScalar(options.output_uncertainty, surface, values,
                            PercentileColorMax(values), error)) {
      return false;
    }
    log << "wrote " << options.output_uncertainty << note << " (standard deviation per vertex)\n";
  } else if (!options.output_uncertainty.empty()) {
    // None this time (the log says why): no earlier run's file may pass for this fit's.
    std::error_code code;
    if (std::filesystem::remove(options.output_uncertainty, code)) {
      log << "removed " << options.output_uncertainty << ": an earlier fit's uncertainty "
          << "(this fit has none)\n";
    }
  }
  return true;
}

// A fit that did not end well: its outputs are written for inspection when they are
// finite, and the status is kNotConverged with `message`.
FitJobResult NotConverged(const FitJobOptions& options, const ActiveModel& model,
                          FitJobResult result, const std::string& message, std::ostream& log) {
  result.status = JobStatus::kNotConverged;
  result.message = message;
  const LatentFitResult& fit = result.fit;
  if (fit.surface.cols() == model.num_surface_vertices() && fit.surface.allFinite() &&
      fit.state.cols() == model.mesh.num_vertices() && fit.state.allFinite() &&
      fit.latent.size() == model.latent_dim() && fit.latent.allFinite()) {
    std::string error;
    if (!WriteFitOutputs(options, model, fit, " (NOT CONVERGED, for inspection)", log, &error)) {
      result.message += "; " + error;
    }
  } else {
    result.message += " (no finite state: nothing written)";
  }
  return result;
}

// For a scan fit compared with the true pose (3 x num_surface_vertices) over `vertices`:
// logs the error over those the scan sees, split along the pose's normals (what a scan
// measures) and across them (a slide along the surface, which it does not), and the error
// over the others (eval/scan_error_split.h).
void LogScanErrorSplit(const Eigen::Matrix3Xd& surface, const SurfaceMesh& truth,
                       const ActiveModel& model, const std::vector<int>& vertices,
                       const Eigen::Matrix3Xd& cloud, std::ostream& log) {
  const std::vector<int> seen = ScannedVertices(truth.vertices, vertices, cloud);
  const Eigen::Matrix3Xd normals = VertexNormals(truth.vertices, model.neutral.triangles);
  const NormalTangentialError split = SplitError(surface, truth.vertices, normals, seen);
  std::vector<char> in_scan(truth.vertices.cols(), 0);
  for (int v : seen) in_scan[v] = 1;
  std::vector<int> unseen;
  for (int v : vertices) {
    if (!in_scan[v]) unseen.push_back(v);
  }
  log << "  of them, " << seen.size() << " within " << kScannedSpacings
      << " scan spacings of a scan point: ";
  if (seen.empty()) {
    log << "n/a";  // an empty set's split is zeros, not a perfect fit
  } else {
    log << "mean " << split.total << ", along the pose's normals " << split.normal
        << " (what a scan measures), across them " << split.tangential;
  }
  log << "; the " << unseen.size() << " others: ";
  if (unseen.empty()) {
    log << "n/a\n";
  } else {
    log << "mean " << SplitError(surface, truth.vertices, normals, unseen).total << "\n";
  }
}

}  // namespace

bool ValidateFitTargetOptions(const std::string& target_kind, const LatentFitOptions& fit,
                              const PointCloudFitOptions& points, std::string* error) {
  std::string fit_error, points_error;
  const bool fit_ok = fit.Validate(&fit_error);
  const bool points_ok = points.Validate(&points_error);
  return OptionChecks()
      .Require(target_kind == "auto" || target_kind == "pose" || target_kind == "markers" ||
                   target_kind == "points",
               "target_kind must be auto, pose, markers or points (is '" + target_kind + "')")
      .Nested("fit", fit_ok, fit_error)
      .Nested("points", points_ok, points_error)
      .Done(error);
}

bool FitJobOptions::Validate(std::string* error) const {
  return ValidateFitTargetOptions(target_kind, fit, points, error);
}

bool ReadMarkerTarget(const std::string& path, const Eigen::Matrix3Xd& neutral,
                      FitTarget* target, std::string* error) {
  std::vector<int> vertices;
  Eigen::Matrix3Xd positions;
  if (!ReadMarkers(path, static_cast<int>(neutral.cols()), &vertices, &positions, error) ||
      !CheckPointsNearModel(path, neutral, positions, error) ||
      !CheckTargetOffsetFromModel(path, neutral, vertices, positions, error)) {
    return false;
  }
  *target = VertexTarget(vertices, positions);
  return true;
}

bool ReadMarkers(const std::string& path, int num_surface_vertices, std::vector<int>* vertices,
                 Eigen::Matrix3Xd* positions, std::string* error) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  std::vector<int> first_line(num_surface_vertices, 0), read;
  std::vector<Eigen::Vector3d> points;
  std::vector<std::string> t;
  while (reader.NextTokens(&t)) {
    int v = 0;
    Eigen::Vector3d p;
    if (t.size() != 4 || !ParseInt(t[0], &v) || !ParseDouble(t[1], &p.x()) ||
        !ParseDouble(t[2], &p.y()) || !ParseDouble(t[3], &p.z())) {
      *error = reader.Where("expected 'vertex x y z' (a surface vertex index and its position)");
      return false;
    }
    if (v < 0 || v >= num_surface_vertices) {
      *error = reader.Where("surface vertex " + std::to_string(v) + " is outside [0, " +
                            std::to_string(num_surface_vertices) + ")");
      return false;
    }
    if (first_line[v] > 0) {
      *error = reader.Where("vertex " + std::to_string(v) + " is given again (first on line " +
                            std::to_string(first_line[v]) + ")");
      return false;
    }
    first_line[v] = reader.line_number();
    read.push_back(v);
    points.push_back(p);
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (read.empty()) {
    *error = path + ": no markers";
    return false;
  }
  *vertices = read;
  positions->resize(3, points.size());
  for (size_t i = 0; i < points.size(); ++i) positions->col(i) = points[i];
  return true;
}

namespace {

// The target of a fit job, as read: its kind ("pose", "markers" or "points"), the target
// with correspondence (pose, markers) or the cloud (points), and the cloud's options
// (with the scan's landmarks, if any).
struct JobTarget {
  std::string kind;
  FitTarget target;
  Eigen::Matrix3Xd cloud;
  PointCloudFitOptions cloud_options;
};

// Reads options.target (of options.target_kind, or told from its extension and vertex
// count) and options.landmarks, each checked against the model. False with *error
// naming the file.
bool ReadJobTarget(const FitJobOptions& options, const ActiveModel& model, JobTarget* job,
                   std::string* error) {
  const int ns = model.num_surface_vertices();
  std::string kind = options.target_kind;
  const std::string ext = LowercaseExtension(options.target);
  SurfaceMesh target_surface;
  auto fail = [error](const std::string& message) {
    *error = message;
    return false;
  };
  if (kind == "auto") {
    if (ext == ".txt") {
      kind = "markers";
    } else if (ext == ".ply") {
      kind = "points";
    } else if (ext == ".obj") {
      if (!ReadObj(options.target, &target_surface, error)) return false;
      if (target_surface.num_vertices() == ns) {
        kind = "pose";
      } else if (target_surface.num_triangles() > 0 ||
                 std::abs(target_surface.num_vertices() - ns) <= ns / 100) {
        // A surface with faces, or points within 1% of the neutral's vertex count, is far
        // more likely a broken pose than a scan: say so rather than fit it as points.
        return fail(options.target + ": a surface with " +
                    std::to_string(target_surface.num_vertices()) +
                    " vertices, but the model's surface has " + std::to_string(ns) +
                    ": a pose target needs the neutral's vertex order; to fit the file as a "
                    "point cloud (a scan), pass --target_kind=points");
      } else {
        kind = "points";
      }
    } else {
      return fail(options.target + ": cannot tell the target kind from the extension; give "
                  "--target_kind=pose|markers|points");
    }
  }
  job->kind = kind;
  const Eigen::Matrix3Xd& neutral = model.neutral.vertices;
  if (kind == "pose") {
    if (target_surface.num_vertices() == 0 && !ReadObj(options.target, &target_surface, error)) {
      return false;
    }
    if (target_surface.num_vertices() != ns) {
      return fail(options.target + ": " + std::to_string(target_surface.num_vertices()) +
                  " vertices, but the model's surface has " + std::to_string(ns) +
                  " (a pose target needs the neutral's vertex order)");
    }
    std::vector<int> all(ns);
    for (int v = 0; v < ns; ++v) all[v] = v;
    if (!CheckPointsNearModel(options.target, neutral, target_surface.vertices, error) ||
        !CheckTargetOffsetFromModel(options.target, neutral, all, target_surface.vertices,
                                    error)) {
      return false;
    }
    job->target = FullSurfaceTarget(target_surface.vertices);
  } else if (kind == "markers") {
    if (!ReadMarkerTarget(options.target, neutral, &job->target, error)) return false;
  } else if (kind == "points") {
    if (!ReadPointCloud(options.target, &job->cloud, error)) return false;
    if (job->cloud.cols() < 3) return fail(options.target + ": fewer than 3 points");
    if (!CheckPointsNearModel(options.target, neutral, job->cloud, error) ||
        !CheckTargetOffsetFromModel(options.target, neutral, {}, job->cloud, error)) {
      return false;
    }
  } else {
    return fail("--target_kind must be auto, pose, markers or points, got '" + kind + "'");
  }
  job->cloud_options = options.points;
  if (!options.landmarks.empty()) {
    if (kind != "points") {
      return fail(options.landmarks + ": --landmarks go with a point cloud (a scan), but " +
                  options.target + " is fitted as " + kind);
    }
    if (!ReadMarkerTarget(options.landmarks, neutral, &job->cloud_options.landmarks, error)) {
      return false;
    }
  }
  return true;
}

// Reads options.compare_to (a surface in the neutral's vertex order, near the model)
// into *truth and checks options.compare_vertices. False with *error naming the file or
// vertex.
bool ReadComparison(const FitJobOptions& options, const ActiveModel& model, SurfaceMesh* truth,
                    std::string* error) {
  const int ns = model.num_surface_vertices();
  if (!ReadObj(options.compare_to, truth, error) ||
      !CheckPointsNearModel(options.compare_to, model.neutral.vertices, truth->vertices, error)) {
    return false;
  }
  if (truth->num_vertices() != ns) {
    *error = options.compare_to + ": " + std::to_string(truth->num_vertices()) +
             " vertices, but the model's surface has " + std::to_string(ns);
    return false;
  }
  for (int v : options.compare_vertices) {
    if (v < 0 || v >= ns) {
      *error = "compare_vertices: comparison vertex " + std::to_string(v) +
               " is outside the surface's " +
               std::to_string(ns) + " vertices";
      return false;
    }
  }
  return true;
}

// Logs what a fit reached and cost: its error over the data, work, second start, scan
// matching and landmarks, uncertainty, latent and bone motions.
void LogFit(const FitJobOptions& options, const ActiveModel& model, const JobTarget& job,
            const LatentFitResult& fit, std::ostream& log) {
  const std::string& kind = job.kind;
  const Eigen::Matrix3Xd& cloud = job.cloud;
  const PointCloudFitOptions& cloud_options = job.cloud_options;
  log << std::setprecision(6) << "fit: " << fit.iterations << " iterations, error mean "
      << fit.mean_error << " rms " << fit.rms_error << " max " << fit.max_error << " over "
      << fit.used_points << " points (" << fit.message << ")\n";
  log << std::setprecision(3) << "work: " << fit.solves << " equilibrium solves ("
      << fit.solve_factorizations << " factorizations, " << fit.solve_seconds << " s), "
      << fit.jacobians << " Jacobians (" << fit.jacobian_seconds << " s"
      << (fit.shifted_jacobians > 0
              ? "; " + std::to_string(fit.shifted_jacobians) +
                    " of a regularized stiffness: the exact one is singular there"
              : std::string())
      << ")\n" << std::setprecision(6);
  if (fit.second_start_ran) {
    log << "second start through " << options.fit.coarse_points << " of the points: "
        << (fit.second_start_kept ? "kept (a smaller objective than the direct fit)"
                                  : "not kept (the direct fit's objective is not larger)")
        << "\n";
  }
  if (kind == "points") {
    log << "scan: " << fit.used_points << " of " << cloud.cols() << " points matched ("
        << 100.0 * fit.matched_fraction << "%), matched distance mean " << fit.mean_error
        << " rms " << fit.rms_error;
    if (!fit.round_distances.empty()) {
      log << "; at each matching round:";
      for (double d : fit.round_distances) log << ' ' << d;
    }
    log << "\n";
    if (cloud_options.landmarks.num_points() > 0) {
      log << "landmarks: " << cloud_options.landmarks.num_points() << " (weight "
          << cloud_options.landmark_weight << "), mean distance " << fit.landmark_mean_error
          << "\n";
    }
  }
  if (!options.output_uncertainty.empty()) {
    if (fit.surface_std.size() > 0) {
      log << "uncertainty: noise sigma " << fit.noise_sigma << "; standard deviation per vertex "
          << "mean " << fit.surface_std.mean() << " max " << fit.surface_std.maxCoeff() << "\n";
    } else {
      log << "uncertainty: not available (" << fit.uncertainty_message << ")\n";
    }
  }
  log << "latent:";
  for (Eigen::Index i = 0; i < fit.latent.size(); ++i) log << ' ' << fit.latent[i];
  log << "\n";
  for (size_t b = 0; b < model.bones.size(); ++b) {
    const Eigen::AngleAxisd aa(fit.bones[b].rotation);
    log << "bone " << model.bones[b].name << ": rotation " << aa.angle() * 180 / M_PI
        << " deg, translation " << fit.bones[b].translation.transpose() << "\n";
  }
}

// Logs the fit's surface against the true one over options.compare_vertices (all if
// empty) and records mean, rms and max in *result; for a scan, also the split of the
// error over what the scan sees (LogScanErrorSplit).
void CompareWithTruth(const FitJobOptions& options, const ActiveModel& model,
                      const JobTarget& job, const SurfaceMesh& truth, FitJobResult* result,
                      std::ostream& log) {
  const LatentFitResult& fit = result->fit;
  const int ns = model.num_surface_vertices();
  const Eigen::VectorXd distances = (fit.surface - truth.vertices).colwise().norm().transpose();
  std::vector<int> vertices = options.compare_vertices;
  if (vertices.empty()) {
    for (int i = 0; i < ns; ++i) vertices.push_back(i);
  }
  double sum = 0, squares = 0, rest_sum = 0;
  for (int v : vertices) {
    sum += distances[v];
    squares += distances[v] * distances[v];
    result->compare_max = std::max(result->compare_max, distances[v]);
    rest_sum += (model.neutral.vertices.col(v) - truth.vertices.col(v)).norm();
  }
  result->compare_mean = sum / vertices.size();
  result->compare_rms = std::sqrt(squares / vertices.size());
  log << "versus " << options.compare_to << " over " << vertices.size()
      << " vertices: mean " << result->compare_mean << " rms " << result->compare_rms << " max "
      << result->compare_max << " (the neutral surface: mean " << rest_sum / vertices.size()
      << ")\n";
  if (job.kind == "points") LogScanErrorSplit(fit.surface, truth, model, vertices, job.cloud, log);
}

}  // namespace

FitJobResult RunFitJob(const FitJobOptions& options, std::ostream& log) {
  WallTimer timer;
  std::string error;
  if (!options.Validate(&error)) return Fail(error);
  if (options.model.empty() || options.target.empty() || options.output.empty()) {
    return Fail("--model, --target and --output are required");
  }
  if (LowercaseExtension(options.output) != ".obj") {
    return Fail(options.output + ": --output must be an .obj");
  }
  if (!options.output_volume.empty() && !IsDeformedMeshOutputPath(options.output_volume)) {
    return Fail(options.output_volume + ": unknown output extension; known: .mesh, .vtu, .obj");
  }
  if (!options.output_uncertainty.empty() &&
      LowercaseExtension(options.output_uncertainty) != ".ply") {
    return Fail(options.output_uncertainty + ": --output_uncertainty must be a .ply");
  }
  if (!CheckOutputsDistinct({options.output, options.output_volume, options.latent_output,
                             options.output_uncertainty},
                            &error)) {
    return Fail(error);
  }
  for (const std::string* output : {&options.output, &options.output_volume, &options.latent_output,
                                    &options.output_uncertainty}) {
    if (output->empty()) continue;
    if (!CheckOutputFile(*output, &error)) return Fail(error);
    for (const std::string* input : {&options.model, &options.target, &options.landmarks,
                                     &options.initial_latent, &options.compare_to}) {
      if (!CheckOutputApart(*output, *input, &error)) return Fail(error);
    }
  }
  ActiveModel model;
  if (!LoadModel(options.model, &model, &error)) return Fail(error);
  if (!model.decoder) return Fail(options.model + ": the model is not trained (no decoder)");
  if (!CheckPointCloudScales(options.points, ModelSize(model.neutral.vertices), &error)) {
    return Fail(error);
  }
  JobTarget job;
  if (!ReadJobTarget(options, model, &job, &error)) return Fail(error);
  const std::string& kind = job.kind;
  SurfaceMesh truth;
  if (!options.compare_to.empty() && !ReadComparison(options, model, &truth, &error)) {
    return Fail(error);
  }
  log << "target " << options.target << ": " << kind << " ("
      << (kind == "points" ? job.cloud.cols() : job.target.num_points()) << " points)\n";

  LatentFitOptions fit_options = options.fit;
  fit_options.uncertainty = fit_options.uncertainty || !options.output_uncertainty.empty();
  LatentFitter fitter(model, fit_options);
  // BLAS threads for this model's factor size (util/blas.h).
  const ScopedBlasThreads blas(BlasThreadsForFactor(fitter.FactorNonzeros(), BlasThreads()));
  Eigen::VectorXd initial = options.start.mean_latent ? fitter.MeanLatent() : fitter.PriorLatent();
  if (!options.initial_latent.empty()) {
    std::vector<RigidTransform> bones;
    LatentFileModel origin;
    std::string warning;
    if (!ReadLatentFile(options.initial_latent, model.latent_dim(), BoneNames(model), &initial,
                        &bones, &origin, &error) ||
        !CheckLatentFileModel(model, options.initial_latent, origin, &warning, &error) ||
        !CheckLatentActuations(model, initial, options.initial_latent, &error) ||
        !CheckBoneMotions(model, bones, options.initial_latent, &error)) {
      return Fail(error);
    }
    if (!warning.empty()) log << "warning: " << warning << "\n";
    fitter.set_bone_transforms(bones);
  }
  FitJobResult result;
  result.kind = kind;
  const bool ok = FitFromChosenStart(&fitter, kind == "points" ? nullptr : &job.target,
                                     kind == "points" ? &job.cloud : nullptr, job.cloud_options,
                                     options.start, initial, &result.fit, &error);
  if (result.fit.start.empty()) {  // no start could be simulated
    result.status = JobStatus::kNotConverged;
    result.message = error;
    return result;
  }
  const LatentFitResult& fit = result.fit;
  if (!fit.retry_reason.empty()) {
    log << "retry from the given start: " << fit.retry_reason << "; "
        << (fit.retry_kept ? "kept (a smaller objective)" : "not kept") << "\n";
  }
  log << "start: " << fit.start << "\n";
  if (!ok) return NotConverged(options, model, result, error, log);
  LogFit(options, model, job, fit, log);
  if (!options.compare_to.empty()) CompareWithTruth(options, model, job, truth, &result, log);
  if (fit.failed || !std::isfinite(fit.mean_error) || !std::isfinite(fit.rms_error) ||
      !std::isfinite(fit.max_error)) {
    return NotConverged(options, model, result,
                        fit.failed ? "the fit failed: " + fit.message
                                   : "the fit's error is not finite (" + fit.message + ")",
                        log);
  }
  if (!WriteFitOutputs(options, model, fit, "", log, &error)) return Fail(error);
  log << "total " << timer.Seconds() << " s\n";
  return result;
}

}  // namespace aqs
