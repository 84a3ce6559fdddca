#ifndef AQS_JOBS_FIT_JOB_H_
#define AQS_JOBS_FIT_JOB_H_

#include <ostream>
#include <string>
#include <vector>

#include "fit/latent_fit.h"
#include "jobs/simulate_job.h"

namespace aqs {

// The checks every fit job's options share: target_kind is auto, pose, markers or
// points, and `fit` and `points` are valid. false with *error naming the first bad field.
bool ValidateFitTargetOptions(const std::string& target_kind, const LatentFitOptions& fit,
                              const PointCloudFitOptions& points, std::string* error);

// What aqs_fit does: fit a trained model's latent (and bone motions) to a target and
// write the result.
struct FitJobOptions {
  std::string model;   // model directory (trained); required
  std::string target;  // target file; required
  // pose: a surface with the neutral's vertex order (OBJ);
  // markers: a text file of "vertex x y z" lines (0-based surface vertex indices);
  // points: a point cloud without correspondence (OBJ 'v' lines or PLY);
  // auto: .txt -> markers, .ply -> points, .obj -> pose if it has the neutral's vertex
  //       count, else points.
  std::string target_kind = "auto";
  // Optional, point clouds only: landmarks of the scan (a markers file, "vertex x y z"
  // lines), fitted with it (PointCloudFitOptions::landmarks, weight
  // points.landmark_weight).
  std::string landmarks;
  std::string output;         // the fitted surface (OBJ, the neutral's faces); required
  std::string output_volume;  // optional: the equilibrium (.vtu/.mesh/.obj by extension)
  std::string latent_output;  // optional: the latent file (io/latent_io.h)
  // Optional: the fitted surface with each vertex's standard deviation (PLY with a
  // scalar, mesh/ply_io.h; LatentFitOptions::uncertainty).
  std::string output_uncertainty;
  std::string initial_latent; // optional start (latent file); default: mean training latent
  // Optional: a ground-truth surface (OBJ, the neutral's vertex order) the fitted surface
  // is measured against, over compare_vertices (empty: all), into FitJobResult.
  std::string compare_to;
  std::vector<int> compare_vertices;
  LatentFitOptions fit;
  PointCloudFitOptions points;
  FitStartOptions start;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

struct FitJobResult {
  JobStatus status = JobStatus::kOk;
  std::string message;
  std::string kind;  // the target kind used
  LatentFitResult fit;
  // With compare_to: vertex distances of the fitted surface to it.
  double compare_mean = 0.0, compare_rms = 0.0, compare_max = 0.0;
};

// Reads a markers file: "vertex x y z" per line ('#' comments), vertices in
// [0, num_surface_vertices), no repeats. Errors name path:line.
bool ReadMarkers(const std::string& path, int num_surface_vertices, std::vector<int>* vertices,
                 Eigen::Matrix3Xd* positions, std::string* error);

// A markers file as a fit target on its vertices (VertexTarget): markers, or a scan's
// landmarks. Errors as ReadMarkers', and the checks every fit target gets: finite and
// within reach of the model (CheckPointsNearModel), and not in another unit or frame
// (CheckTargetOffsetFromModel against the neutral surface's vertices `neutral`, whose
// count bounds the marker vertices).
bool ReadMarkerTarget(const std::string& path, const Eigen::Matrix3Xd& neutral,
                      FitTarget* target, std::string* error);

// Runs aqs_fit on one target: loads the trained model, reads the target (its kind as
// options.target_kind says), chooses a start (FitFromChosenStart: options.start, or
// options.initial_latent and its bone motions), fits the latent and bone motions
// (LatentFitter), compares with options.compare_to if given, writes the outputs that
// are set (the surface as OBJ in the neutral's vertex order, the volume, the latent
// file, the uncertainty PLY; each atomically) and logs to `log`. Status: kOk; kBadInput
// for invalid options, unreadable or mismatched inputs or an output that cannot be
// written; kNotConverged if no start could be simulated (nothing written), or the fit
// failed or its errors are not finite (its finite outputs written, for inspection). A fit
// that stops at its iteration limit is kOk (the log says so).
// result.fit holds the fit, result.kind the target kind used.
FitJobResult RunFitJob(const FitJobOptions& options, std::ostream& log);

}  // namespace aqs

#endif  // AQS_JOBS_FIT_JOB_H_
