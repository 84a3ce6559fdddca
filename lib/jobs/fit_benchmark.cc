#include "jobs/fit_benchmark.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>
#include <utility>

#include <Eigen/Geometry>
#include <glog/logging.h>

#include "equilibrium/stiffness_factorization.h"
#include "eval/scan_error_split.h"
#include "eval/surface_pca.h"
#include "fit/chosen_start_fit.h"
#include "geometry/points_near_model.h"
#include "geometry/vertex_normals.h"
#include "io/vertex_list_io.h"
#include "jobs/fit_benchmark_report.h"
#include "jobs/fit_sequence.h"
#include "mesh/mesh_io.h"
#include "mesh/ply_io.h"
#include "model/model_io.h"
#include "util/atomic_file.h"
#include "util/blas.h"
#include "util/input_file.h"
#include "util/line_reader.h"
#include "util/machine_info.h"
#include "util/number_format.h"
#include "util/option_checks.h"
#include "util/path_lock.h"
#include "util/wall_timer.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;
using fit_benchmark::Fixed;
using fit_benchmark::Max;
using fit_benchmark::Mean;
using fit_benchmark::Median;
using Row = FitBenchmarkRow;

// Pearson's correlation of a and b (same size; NaN if either is constant).
double Correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = a.size();
  double ma = 0, mb = 0;
  for (size_t i = 0; i < n; ++i) {
    ma += a[i] / n;
    mb += b[i] / n;
  }
  double ab = 0, aa = 0, bb = 0;
  for (size_t i = 0; i < n; ++i) {
    ab += (a[i] - ma) * (b[i] - mb);
    aa += (a[i] - ma) * (a[i] - ma);
    bb += (b[i] - mb) * (b[i] - mb);
  }
  return aa > 0 && bb > 0 ? ab / std::sqrt(aa * bb) : std::nan("");
}

Row MakeRow(const std::string& mix, const std::string& method, int markers) {
  Row r;
  r.mix = mix;
  r.method = method;
  r.markers = markers;
  return r;
}

void Errors(const Eigen::Matrix3Xd& surface, const Eigen::Matrix3Xd& truth,
            const std::vector<int>& vertices, double* mean, double* max) {
  double sum = 0, worst = 0;
  for (int v : vertices) {
    const double d = (surface.col(v) - truth.col(v)).norm();
    sum += d;
    worst = std::max(worst, d);
  }
  *mean = sum / vertices.size();
  *max = worst;
}

// The mix names of mixes.csv (first column after the header).
bool ReadMixes(const std::string& path, std::vector<std::string>* mixes, std::string* error) {
  LineReader reader(path);
  if (!reader.ok()) {
    *error = reader.error() + " (make the test set with scripts/make_fit_tests.py)";
    return false;
  }
  std::set<std::string> seen;
  while (reader.NextLine()) {
    if (reader.line_number() == 1) {
      if (reader.line().compare(0, 4, "mix,") != 0) {
        *error = reader.Where("expected the header 'mix,...' (a test set of "
                              "scripts/make_fit_tests.py)");
        return false;
      }
      continue;
    }
    if (reader.line().empty()) continue;
    const std::string name = reader.line().substr(0, reader.line().find(','));
    if (name.empty()) {
      *error = reader.Where("expected 'mix,expressions'");
      return false;
    }
    if (!seen.insert(name).second) {
      *error = reader.Where("mix '" + name + "' is listed again");
      return false;
    }
    mixes->push_back(name);
  }
  if (!reader.ok()) {
    *error = reader.error();
    return false;
  }
  if (mixes->empty()) {
    *error = path + ": lists no mix";
    return false;
  }
  return true;
}


double JawDegrees(const std::vector<RigidTransform>& bones) {
  if (bones.empty()) return 0.0;
  return Eigen::AngleAxisd(bones[0].rotation).angle() * 180.0 / M_PI;
}

// Median seconds of numeric factorizations of the model's exact stiffness at rest: the
// unit fit times are also given in (load-independent work; docs/benchmarks.md).
double FactorizationUnit(const ActiveModel& model, int threads) {
  const ShapeTargetModel physics(model.mesh, model.mu);
  const BoundaryConditions bc = ModelBoundaryConditions(model, RestBoneTransforms(model));
  StiffnessFactorization factorization(physics, FixedVertexMask(bc, physics.num_vertices()), threads);
  factorization.Assemble(model.mesh.vertices, IdentityActuations(physics.num_elements()),
                         StiffnessKind::kExact);
  std::vector<double> seconds;
  std::string error;
  for (int i = 0; i < 6; ++i) {
    WallTimer timer;
    if (!factorization.FactorizeAssembled(0.0, &error)) return 0.0;
    if (i > 0) seconds.push_back(timer.Seconds());  // the first one includes the analysis
  }
  return Median(seconds);
}

// The physics fits of one benchmark run, mix after mix, and the rows so far (each
// printed as it is added: progress of a long run). Every fit starts alike: the prior's
// centre (or the mean latent), bones at rest, the rest shape, then the start choice as
// aqs_fit's.
class BenchmarkFits {
 public:
  BenchmarkFits(const FitBenchmarkOptions& options, const ActiveModel& model,
                const std::vector<int>& measured, std::ostream& log)
      : options_(options), model_(model), measured_(measured), log_(log),
        fitter_(model, options.fit), rest_(RestBoneTransforms(model)) {}

  LatentFitter& fitter() { return fitter_; }
  const std::vector<Row>& rows() const { return rows_; }

  // Adds a reference row (the neutral, PCA).
  void Add(const Row& row) {
    rows_.push_back(row);
    Print(row);
  }

  // A new mix: no fit with correspondence yet, no scan.
  void StartMix() {
    pose_fit_ = nullptr;
    scanned_.clear();
    unscanned_.clear();
  }

  // The mix's scan: the measured vertices it sees (on the true surface, 3 x N) and does
  // not see, and the true surface's unit vertex normals, by which scan fits' errors are
  // split.
  void SetScan(const Eigen::Matrix3Xd& truth, const Eigen::Matrix3Xd& cloud) {
    scanned_ = ScannedVertices(truth, measured_, cloud);
    unscanned_.clear();
    std::vector<char> seen(truth.cols(), 0);
    for (int v : scanned_) seen[v] = 1;
    for (int v : measured_) {
      if (!seen[v]) unscanned_.push_back(v);
    }
    truth_normals_ = VertexNormals(truth, model_.neutral.triangles);
  }

  // A physics fit to a target or a cloud, timed from the start choice to the result,
  // added as a row; with `from` (clouds only), from its latent and bones without a start
  // choice. The mix's fit with correspondence (PoseFit) judges scan fits. True if it
  // succeeded.
  bool Physics(const std::string& mix, const std::string& method, int markers,
               const FitTarget* target, const Eigen::Matrix3Xd* cloud,
               const PointCloudFitOptions& cloud_options, const Eigen::Matrix3Xd& truth,
               const LatentFitResult* from = nullptr) {
    LatentFitResult fit;
    return Fit(mix, method, markers, target, cloud, cloud_options, truth, from, &fit);
  }

  // The mix's fit with correspondence (method "physics_pose"), kept for its scan fits;
  // nullptr if it failed.
  const LatentFitResult* PoseFit(const std::string& mix, const Eigen::Matrix3Xd& truth) {
    const FitTarget target = FullSurfaceTarget(truth);
    if (!Fit(mix, "physics_pose", 0, &target, nullptr, options_.points, truth, nullptr,
             &pose_result_)) {
      return nullptr;
    }
    pose_fit_ = &pose_result_;
    return pose_fit_;
  }

 private:
  bool Fit(const std::string& mix, const std::string& method, int markers,
           const FitTarget* target, const Eigen::Matrix3Xd* cloud,
           const PointCloudFitOptions& cloud_options, const Eigen::Matrix3Xd& truth,
           const LatentFitResult* from, LatentFitResult* fit);
  // The row's error split over what the scan sees (scan fits), and the scan's objective
  // at the fit with correspondence over this fit's.
  void JudgeScanFit(const LatentFitResult& fit, const Eigen::Matrix3Xd& truth,
                    const Eigen::Matrix3Xd& cloud, const PointCloudFitOptions& cloud_options,
                    Row* r);
  void Print(const Row& r);

  const FitBenchmarkOptions& options_;
  const ActiveModel& model_;
  const std::vector<int>& measured_;
  std::ostream& log_;
  LatentFitter fitter_;
  const std::vector<RigidTransform> rest_;
  std::vector<Row> rows_;
  LatentFitResult pose_result_;
  const LatentFitResult* pose_fit_ = nullptr;  // the mix's, where it succeeded
  std::vector<int> scanned_, unscanned_;
  Eigen::Matrix3Xd truth_normals_;
};

void BenchmarkFits::Print(const Row& r) {
  log_ << std::left << std::setw(8) << r.mix << " " << std::setw(16)
       << (r.method + (r.markers > 0 ? "_m" + std::to_string(r.markers) : "")) << std::right
       << " mean " << Fixed(r.mean, 4) << " max " << Fixed(r.max, 3);
  if (r.method.rfind("physics", 0) == 0) {
    log_ << "  " << Fixed(r.seconds, 2) << " s (solves " << r.solves << "/" << r.factorizations
         << " fact. " << Fixed(r.solve_seconds, 2) << " s, jacobians " << r.jacobians << " "
         << Fixed(r.jacobian_seconds, 2) << " s), " << r.iterations << " it, jaw "
         << Fixed(r.jaw_degrees, 1) << " deg" << (r.converged ? "" : ", not converged")
         << ", start " << r.start;
  }
  if (r.method.rfind("physics_scan", 0) == 0) {
    log_ << ", matched " << Fixed(100 * r.matched_fraction, 1) << "% at "
         << Fixed(r.matched_distance, 4);
  }
  log_ << std::endl;  // progress of a long run
}

bool BenchmarkFits::Fit(const std::string& mix, const std::string& method, int markers,
                        const FitTarget* target, const Eigen::Matrix3Xd* cloud,
                        const PointCloudFitOptions& cloud_options,
                        const Eigen::Matrix3Xd& truth, const LatentFitResult* from,
                        LatentFitResult* kept) {
  // Every fit starts alike, as aqs_fit's would: at rest, without the factor of the fit
  // before (its first solve would reuse it by CG, so a row depended on the rows before).
  fitter_.set_bone_transforms(rest_);
  fitter_.set_start_state(model_.mesh.vertices);
  fitter_.ForgetFactor();
  WallTimer timer;
  Eigen::VectorXd z = options_.start.mean_latent ? fitter_.MeanLatent() : fitter_.PriorLatent();
  std::string fit_error;
  LatentFitResult fit;
  Row r = MakeRow(mix, method, markers);
  bool ok = false;
  if (from != nullptr) {
    CHECK(cloud != nullptr) << "a fit from another fit's result is a scan's";
    fitter_.set_bone_transforms(from->bones);
    fitter_.set_start_state(from->state);
    ok = fitter_.FitPointCloud(*cloud, cloud_options, from->latent, &fit, &fit_error);
    fit.start = "the fit with correspondence";
  } else {
    ok = FitFromChosenStart(&fitter_, target, cloud, cloud_options, options_.start, z, &fit,
                            &fit_error);
  }
  r.seconds = timer.Seconds();
  r.start = fit.start + (fit.retry_reason.empty() ? "" : fit.retry_kept ? " (retried, kept)"
                                                                        : " (retried)");
  // A fit whose minimizer failed (Ceres' FAILURE) has no result either: aqs_fit exits 2
  // for it, sequences mark it -1 and the evaluation n/a (it became a row with errors).
  if (ok && fit.failed) {
    ok = false;
    fit_error = "the fit failed: " + fit.message;
  }
  if (!ok) {
    r.converged = false;
    r.mean = r.max = std::nan("");
    log_ << mix << " " << method << ": " << fit_error << "\n";
  } else {
    Errors(fit.surface, truth, measured_, &r.mean, &r.max);
    r.iterations = fit.iterations;
    r.converged = fit.converged;
    r.jaw_degrees = JawDegrees(fit.bones);
    r.matched_fraction = fit.matched_fraction;
    r.matched_distance = fit.mean_error;
    r.solves = fit.solves;
    r.factorizations = fit.solve_factorizations;
    r.solve_seconds = fit.solve_seconds;
    r.jacobians = fit.jacobians;
    r.jacobian_seconds = fit.jacobian_seconds;
    if (fit.surface_std.size() == fit.surface.cols()) {
      std::vector<double> predicted, errors;
      for (int v : measured_) {
        predicted.push_back(fit.surface_std[v]);
        errors.push_back((fit.surface.col(v) - truth.col(v)).norm());
      }
      r.predicted_std = Mean(predicted);
      r.std_error_correlation = Correlation(predicted, errors);
    }
    if (cloud != nullptr) JudgeScanFit(fit, truth, *cloud, cloud_options, &r);
  }
  if (ok) *kept = fit;
  rows_.push_back(r);
  Print(r);
  return ok;
}

void BenchmarkFits::JudgeScanFit(const LatentFitResult& fit, const Eigen::Matrix3Xd& truth,
                                 const Eigen::Matrix3Xd& cloud,
                                 const PointCloudFitOptions& cloud_options, Row* r) {
  if (!scanned_.empty()) {
    r->scanned = static_cast<int>(scanned_.size());
    r->scanned_error = SplitError(fit.surface, truth, truth_normals_, scanned_);
    if (!unscanned_.empty()) {
      r->unscanned_error = SplitError(fit.surface, truth, truth_normals_, unscanned_).total;
    }
    if (pose_fit_ != nullptr) {
      r->pose_fit_scanned_error = SplitError(pose_fit_->surface, truth, truth_normals_, scanned_);
      if (!unscanned_.empty()) {
        r->pose_fit_unscanned_error =
            SplitError(pose_fit_->surface, truth, truth_normals_, unscanned_).total;
      }
    }
  }
  if (pose_fit_ == nullptr) return;
  fitter_.set_bone_transforms(pose_fit_->bones);
  const double at_pose_fit = fitter_.StartObjective(nullptr, &cloud, cloud_options,
                                                    pose_fit_->surface, pose_fit_->latent);
  fitter_.set_bone_transforms(fit.bones);
  r->pose_fit_objective_ratio =
      at_pose_fit / fitter_.StartObjective(nullptr, &cloud, cloud_options, fit.surface,
                                           fit.latent);
}


// The PCA baseline's ridge weight per marker set (marker_sets/mK.txt, read into
// *marker_sets): chosen by leave-one-out over the model's training surfaces, logged.
bool ChooseRidges(const FitBenchmarkOptions& options, const ActiveModel& model,
                  const std::vector<Eigen::Matrix3Xd>& training, const std::vector<int>& measured,
                  std::map<int, std::vector<int>>* marker_sets, std::map<int, double>* ridge,
                  std::ostream& log, std::string* error) {
  const int ns = model.num_surface_vertices();
  if (!options.marker_counts.empty() && training.size() < 3) {
    *error = "the markers' ridge PCA baseline chooses its ridge by leave-one-out over at least "
             "3 training poses; the model has " + std::to_string(training.size()) +
             " (leave markers out of --parts)";
    return false;
  }
  for (int k : options.marker_counts) {
    const std::string path = options.test_set + "/marker_sets/m" + std::to_string(k) + ".txt";
    if (!ReadVertexList(path, ns, &(*marker_sets)[k], error)) return false;
    const RidgeChoice choice = ChooseRidgeLeaveOneOut(training, model.latent_dim(),
                                                      (*marker_sets)[k], measured,
                                                      options.ridge_candidates);
    (*ridge)[k] = choice.ridge;
    log << "ridge PCA, " << k << " markers: leave-one-out over " << training.size()
        << " training poses (PCA of the others, "
        << std::min(model.latent_dim(), model.num_poses() - 2) << " components):";
    for (size_t c = 0; c < choice.candidates.size(); ++c) {
      log << " " << choice.candidates[c] << ":" << Fixed(choice.errors[c], 4);
    }
    log << " -> ridge " << choice.ridge << "\n";
  }
  return true;
}

// Every file the mixes' fits read exists (poses/, markers/, scans/ as the parts ask):
// checked before any fit, so that a missing file cannot stop the run half way.
bool CheckMixFiles(const FitBenchmarkOptions& options, const std::vector<std::string>& mixes,
                   std::string* error) {
  for (const std::string& mix : mixes) {
    std::vector<std::string> paths = {options.test_set + "/poses/" + mix + ".obj"};
    if (options.markers) {
      for (int k : options.marker_counts) {
        paths.push_back(options.test_set + "/markers/" + mix + "_m" + std::to_string(k) +
                        ".txt");
      }
    }
    if (options.scans) paths.push_back(options.test_set + "/scans/" + mix + ".ply");
    for (const std::string& path : paths) {
      if (!MayExist(path)) {
        *error = path + ": missing (mix '" + mix + "' of " + options.test_set + "/mixes.csv)";
        return false;
      }
    }
  }
  return true;
}

// The baselines and physics fits of one mix, added to *fits: the neutral, ridge PCA and
// the physics fit per marker set, PCA and the physics fit of the pose, and the scan's
// fits (with its landmarks where the test set has them).
bool FitMix(const FitBenchmarkOptions& options, const ActiveModel& model, const SurfacePca& pca,
            const std::vector<int>& measured, const std::map<int, double>& ridge,
            const std::string& mix, BenchmarkFits* fits, std::string* error) {
  const int ns = model.num_surface_vertices();
  fits->StartMix();
  SurfaceMesh truth;
  const std::string pose_path = options.test_set + "/poses/" + mix + ".obj";
  if (!ReadObj(pose_path, &truth, error)) return false;
  if (truth.num_vertices() != ns) {
    *error = pose_path + ": " + std::to_string(truth.num_vertices()) +
             " vertices, the model has " + std::to_string(ns);
    return false;
  }
  Row neutral = MakeRow(mix, "neutral", 0);
  Errors(model.neutral.vertices, truth.vertices, measured, &neutral.mean, &neutral.max);
  fits->Add(neutral);
  if (options.markers) {
    for (int k : options.marker_counts) {
      const std::string path =
          options.test_set + "/markers/" + mix + "_m" + std::to_string(k) + ".txt";
      std::vector<int> vertices;
      Eigen::Matrix3Xd positions;
      if (!ReadMarkers(path, ns, &vertices, &positions, error)) return false;
      Row p = MakeRow(mix, "pca", k);
      Errors(pca.FitToVerticesRidge(vertices, positions, ridge.at(k)), truth.vertices, measured,
             &p.mean, &p.max);
      fits->Add(p);
      const FitTarget target = VertexTarget(vertices, positions);
      fits->Physics(mix, "physics", k, &target, nullptr, options.points, truth.vertices);
    }
  }
  const LatentFitResult* pose_fit = nullptr;
  if (options.poses) {
    Row p = MakeRow(mix, "pca_pose", 0);
    Errors(pca.Decode(pca.Encode(truth.vertices)), truth.vertices, measured, &p.mean, &p.max);
    fits->Add(p);
    pose_fit = fits->PoseFit(mix, truth.vertices);
  }
  if (!options.scans) return true;
  Eigen::Matrix3Xd cloud;
  const std::string path = options.test_set + "/scans/" + mix + ".ply";
  if (!ReadPointCloud(path, &cloud, error)) return false;
  fits->SetScan(truth.vertices, cloud);
  fits->Physics(mix, "physics_scan", 0, nullptr, &cloud, options.points, truth.vertices);
  // The same scan with its landmarks, where the test set has them.
  const std::string landmarks = options.test_set + "/scans/" + mix + "_landmarks.txt";
  if (MayExist(landmarks)) {
    PointCloudFitOptions with_landmarks = options.points;
    if (!ReadMarkerTarget(landmarks, model.neutral.vertices, &with_landmarks.landmarks, error)) {
      return false;
    }
    fits->Physics(mix, "physics_scan_landmarks", 0, nullptr, &cloud, with_landmarks,
                  truth.vertices);
  }
  if (options.scan_from_pose_fit && pose_fit != nullptr) {
    fits->Physics(mix, "physics_scan_from_pose", 0, nullptr, &cloud, options.points,
                  truth.vertices, pose_fit);
  }
  return true;
}

// The marker sequence fitted by RunFitSequence (into output_dir/sequence) and its
// errors against the truth frames: the report's paragraph (*md). A frame that cannot be
// fitted fails it (status and *error), after the frames before it are written.
JobStatus BenchmarkSequence(const FitBenchmarkOptions& options, const FitSequenceOptions& sequence,
                            const ActiveModel& model, const std::vector<int>& measured,
                            std::string* md, std::ostream& log, std::string* error) {
  std::error_code code;
  // The folder's writers' lock before it is emptied (RunFitSequence takes it again): a
  // sequence another process is fitting there keeps its frames.
  PathLock lock;
  if (!lock.Acquire(sequence.output_dir, error, "the sequence folder " + sequence.output_dir)) {
    return JobStatus::kBadInput;
  }
  if (fs::exists(sequence.output_dir, code)) {
    log << "sequence: emptied " << sequence.output_dir << ": the benchmark fits and times every "
        << "frame (an earlier run's frames are not resumed)\n";
  }
  fs::remove_all(sequence.output_dir, code);
  const FitSequenceResult result = RunFitSequence(sequence, model, log);
  if (result.status != JobStatus::kOk) {
    *error = "the marker sequence: " + result.message;
    return result.status;
  }
  std::vector<double> err, velocity_err;
  SurfaceMesh previous_truth, previous_fitted;
  for (const std::string& name : result.frame_names) {
    SurfaceMesh truth, fitted;
    const std::string truth_path = options.test_set + "/sequence/truth/" + name + ".obj";
    if (!ReadObj(truth_path, &truth, error) ||
        !ReadObj(sequence.output_dir + "/" + name + ".obj", &fitted, error)) {
      return JobStatus::kBadInput;
    }
    double mean = 0, max = 0;
    Errors(fitted.vertices, truth.vertices, measured, &mean, &max);
    err.push_back(mean);
    if (previous_truth.vertices.cols() > 0) {
      // The motion since the frame before, against the truth's: what jitter adds.
      Errors(fitted.vertices - previous_fitted.vertices, truth.vertices - previous_truth.vertices,
             measured, &mean, &max);
      velocity_err.push_back(mean);
    }
    previous_truth = std::move(truth);
    previous_fitted = std::move(fitted);
  }
  std::ostringstream out;
  out << "\nMarker sequence (" << result.frame_names.size() << " frames): "
      << Fixed(result.frames_per_second, 2) << " frames/s (" << Fixed(result.seconds, 1)
      << " s), mean error " << Fixed(Mean(err), 4) << ", max of frames "
      << Fixed(Max(err), 4) << "; frame-to-frame motion error (the mean distance of each "
      << "vertex's motion since the frame before from the truth's) "
      << (velocity_err.empty() ? std::string("n/a (one frame)") : Fixed(Mean(velocity_err), 4));
  if (sequence.temporal_prior > 0) {
    out << "; temporal prior " << FormatDouble(sequence.temporal_prior);
  }
  out << ".\n";
  *md = out.str();
  return JobStatus::kOk;
}

}  // namespace

bool FitBenchmarkOptions::Validate(std::string* error) const {
  std::string fit_error, points_error;
  const bool fit_ok = fit.Validate(&fit_error);
  const bool points_ok = points.Validate(&points_error);
  bool ridges_ok = !ridge_candidates.empty();
  for (double r : ridge_candidates) ridges_ok = ridges_ok && std::isfinite(r) && r >= 0;
  bool counts_ok = true;
  for (int k : marker_counts) counts_ok = counts_ok && k >= 1;
  return OptionChecks()
      .Require(!model.empty(), "model is required")
      .Require(!test_set.empty(), "test_set is required")
      .Require(!output_dir.empty(), "output_dir is required")
      .Require(ridges_ok, "ridge_candidates must be finite and >= 0")
      .Require(counts_ok, "marker_counts must be >= 1")
      .Require(!markers || !marker_counts.empty(),
               "marker_counts must list a count for the markers part")
      .Require(sequence_frames != 0, "sequence_frames must be >= 1, or < 0 for all frames")
      .NonNegative("temporal_prior", temporal_prior)
      .Require(temporal_prior <= 0 || sequence,
               "temporal_prior applies to the sequence part (--parts=...,sequence)")
      .Nested("fit", fit_ok, fit_error)
      .Nested("points", points_ok, points_error)
      .Done(error);
}

JobStatus RunFitBenchmark(const FitBenchmarkOptions& options, std::ostream& log,
                          std::string* error) {
  if (!options.Validate(error)) return JobStatus::kBadInput;
  // The sequence part empties output_dir/sequence first.
  const std::string sequence_dir = options.output_dir + "/sequence";
  if (!CheckOutputApart(options.output_dir, options.model, error) ||
      !CheckOutputApart(options.output_dir, options.test_set, error) ||
      (options.sequence && (!CheckInputOutside(options.model, sequence_dir, error) ||
                            !CheckInputOutside(options.test_set, sequence_dir, error)))) {
    return JobStatus::kBadInput;
  }
  std::error_code code;
  fs::create_directories(options.output_dir, code);
  if (code) {
    *error = options.output_dir + ": cannot create the folder (" + code.message() + ")";
    return JobStatus::kBadInput;
  }
  const std::string csv_path = options.output_dir + "/fit_benchmark.csv";
  const std::string md_path = options.output_dir + "/fit_benchmark.md";
  if (!CheckOutputFile(csv_path, error) || !CheckOutputFile(md_path, error)) {
    return JobStatus::kBadInput;
  }
  // The temporaries of the tables a killed run left (util/atomic_file.h): they stayed for
  // good, one more with each such kill. Those of a running process are kept.
  std::vector<std::string> removed;
  if (!RemoveStaleTemporaryFiles(
          options.output_dir,
          [](const std::string& name) {
            return name == "fit_benchmark.csv" || name == "fit_benchmark.md";
          },
          &removed, error)) {
    return JobStatus::kBadInput;
  }
  for (const std::string& line : removed) log << "cleanup: " << line << "\n";
  ActiveModel model;
  if (!LoadModel(options.model, &model, error)) return JobStatus::kBadInput;
  if (!model.decoder) {
    *error = options.model + ": the model is not trained";
    return JobStatus::kBadInput;
  }
  if (!CheckPointCloudScales(options.points, ModelSize(model.neutral.vertices), error)) {
    return JobStatus::kBadInput;
  }
  const int ns = model.num_surface_vertices();
  std::vector<int> measured = options.error_vertices;
  if (measured.empty()) {
    for (int v = 0; v < ns; ++v) measured.push_back(v);
  }
  for (int v : measured) {
    if (v < 0 || v >= ns) {
      *error = "error_vertices: error vertex " + std::to_string(v) + " is outside the surface's " +
               std::to_string(ns) + " vertices";
      return JobStatus::kBadInput;
    }
  }
  std::vector<std::string> mixes;
  if (!ReadMixes(options.test_set + "/mixes.csv", &mixes, error)) return JobStatus::kBadInput;
  if (options.max_mixes >= 0 && static_cast<int>(mixes.size()) > options.max_mixes) {
    mixes.resize(options.max_mixes);
  }
  if (!CheckMixFiles(options, mixes, error)) return JobStatus::kBadInput;
  // The sequence and its truth frames are checked before any fit, so that bad input
  // there cannot throw away the fits' results at the end. (RunFitSequence reads the
  // frames again: a second read of small marker files, kept rather than a second entry
  // point into the sequence job.)
  FitSequenceOptions sequence;
  sequence.sequence = options.test_set + "/sequence/markers";
  sequence.output_dir = sequence_dir;
  sequence.model = options.model;
  sequence.fit = options.fit;
  // The frames' covariances would only slow the frames per second the benchmark reports
  // (the sequence writes none).
  sequence.fit.uncertainty = false;
  sequence.points = options.points;
  sequence.start = options.start;
  sequence.max_frames = options.sequence_frames;
  sequence.temporal_prior = options.temporal_prior;
  if (options.sequence) {
    std::vector<SequenceFrame> frames;
    if (!ReadSequenceFrames(sequence, model.neutral.vertices, &frames, error)) {
      return JobStatus::kBadInput;
    }
    for (const SequenceFrame& frame : frames) {
      const std::string truth = options.test_set + "/sequence/truth/" + frame.name + ".obj";
      if (!MayExist(truth)) {
        *error = "the sequence frame " + frame.origin + " has no truth surface '" + truth + "'";
        return JobStatus::kBadInput;
      }
      SurfaceMesh surface;
      if (!ReadObj(truth, &surface, error)) return JobStatus::kBadInput;
      if (surface.num_vertices() != ns) {
        *error = truth + ": " + std::to_string(surface.num_vertices()) +
                 " vertices, the model has " + std::to_string(ns);
        return JobStatus::kBadInput;
      }
    }
  }

  // The PCA baseline: the model's own training surfaces, the model's latent size, a
  // ridge weight per marker set chosen by leave-one-out over those surfaces.
  std::vector<Eigen::Matrix3Xd> training;
  for (const TrainingPose& pose : model.poses) training.push_back(pose.surface);
  const SurfacePca pca(training, model.latent_dim());
  std::map<int, std::vector<int>> marker_sets;
  std::map<int, double> ridge;
  if (options.markers &&
      !ChooseRidges(options, model, training, measured, &marker_sets, &ridge, log, error)) {
    return JobStatus::kBadInput;
  }
  log << "PCA: " << pca.num_components() << " components of the " << training.size()
      << " training poses\n";

  const double unit_before = FactorizationUnit(model, options.fit.num_threads);
  log << "one factorization of the stiffness at rest: " << Fixed(unit_before, 4) << " s\n";
  BenchmarkFits fits(options, model, measured, log);
  // BLAS threads for this model's factor size (util/blas.h).
  const ScopedBlasThreads blas(
      BlasThreadsForFactor(fits.fitter().FactorNonzeros(), BlasThreads()));
  // From here a failure still writes the rows fitted before it.
  JobStatus status = JobStatus::kOk;
  size_t mixes_done = 0;
  for (; mixes_done < mixes.size(); ++mixes_done) {
    if (!FitMix(options, model, pca, measured, ridge, mixes[mixes_done], &fits, error)) {
      status = JobStatus::kBadInput;
      break;
    }
  }
  std::string sequence_md;
  if (status == JobStatus::kOk && options.sequence) {
    status = BenchmarkSequence(options, sequence, model, measured, &sequence_md, log, error);
  }

  std::ostringstream md;
  md << "Test set " << options.test_set << ": " << mixes.size() << " mixes; errors in model units "
     << "(mean vertex distance over " << measured.size() << " vertices).\n\n";
  if (status != JobStatus::kOk) {
    md << "**Stopped early** (" << mixes_done << " of " << mixes.size()
       << " mixes fitted): " << *error << "\n\n";
  }
  FitBenchmarkParts parts;
  parts.markers = options.markers;
  parts.poses = options.poses;
  parts.scans = options.scans;
  parts.marker_counts = options.marker_counts;
  parts.uncertainty = options.fit.uncertainty;
  md << FitBenchmarkTables(fits.rows(), parts, measured.size()) << sequence_md;
  const double unit_after = FactorizationUnit(model, options.fit.num_threads);
  md << "\nOne factorization of the stiffness at rest (the unit of solver work): "
     << Fixed(unit_before, 4) << " s before the fits, " << Fixed(unit_after, 4)
     << " s after them (the machine's load shows in the difference).\n";
  md << "\n" << BenchmarkMachineLine() << " (at the end).\n";
  log << "\n" << md.str();
  std::string write_error;
  // The tables go as a pair: an earlier run's .md is removed before the new CSV replaces
  // its CSV, so a kill between the two renames leaves a CSV without its .md, never the
  // .md of another run beside it (a rerun writes both).
  std::error_code remove_code;
  std::filesystem::remove(md_path, remove_code);
  if (remove_code) {
    write_error = md_path + ": cannot remove the earlier run's table: " + remove_code.message();
  }
  if (remove_code || !WriteFileAtomically(csv_path, FitBenchmarkCsv(fits.rows()), &write_error) ||
      !WriteFileAtomically(md_path, md.str(), &write_error)) {
    *error = status == JobStatus::kOk ? write_error : *error + "; and " + write_error;
    return JobStatus::kBadInput;
  }
  log << "wrote " << csv_path << " and fit_benchmark.md"
      << (status == JobStatus::kOk ? "" : " (the rows fitted before the failure)") << "\n";
  return status;
}

}  // namespace aqs
