#ifndef AQS_JOBS_FIT_BENCHMARK_H_
#define AQS_JOBS_FIT_BENCHMARK_H_

#include <ostream>
#include <string>
#include <vector>

#include "jobs/fit_job.h"

namespace aqs {

// What aqs_bench_fit does: fits a trained model to a test set made by
// scripts/make_fit_tests.py (mixes.csv, poses/, marker_sets/, markers/, scans/ (with
// mix_NNN_landmarks.txt where present, also fitted as "physics_scan_landmarks"),
// sequence/) and compares with ridge PCA and the neutral face. Each scan fit is also
// judged by its own objective (LatentFitter::StartObjective, data and latent prior):
// whether the fit with correspondence's surface scores lower (the scan fit stopped in a
// worse minimum) or higher (the scan itself prefers the wrong pose).
struct FitBenchmarkOptions {
  std::string model;     // trained model directory; required
  std::string test_set;  // the generator's output folder; required
  std::string output_dir;  // fit_benchmark.csv and fit_benchmark.md (atomic); required
  std::vector<int> error_vertices;  // surface vertices measured (empty: all)
  std::vector<int> marker_counts = {20, 60};  // markers/mix_NNN_mK.txt for each K
  bool markers = true, poses = true, scans = true, sequence = false;
  int max_mixes = -1;       // < 0: all
  int sequence_frames = -1;  // < 0: all frames of sequence/markers
  // The sequence's temporal prior (FitSequenceOptions::temporal_prior; 0: off).
  double temporal_prior = 0.0;
  // Candidate ridge weights (squared lengths) of the PCA baseline, chosen by
  // leave-one-out over the model's training poses per marker set.
  std::vector<double> ridge_candidates = {0,    1e-6, 3e-6, 1e-5, 3e-5, 1e-4, 3e-4, 1e-3,
                                          3e-3, 1e-2, 3e-2, 0.1,  0.3,  1,    3,    10};
  // Diagnostic (with poses and scans): each scan also fitted from the fit with
  // correspondence's latent and bones, without a start choice ("physics_scan_from_pose"):
  // how far the scan's own objective pulls a fit away from that answer.
  bool scan_from_pose_fit = false;
  LatentFitOptions fit;
  PointCloudFitOptions points;
  FitStartOptions start;

  // Checks every field; false with *error naming the first bad one (util/option_checks.h).
  bool Validate(std::string* error) const;
};

// Returns kOk, or kBadInput with a message naming the file at fault (every file the
// mixes and the sequence read is checked to exist, and every output path to be
// writable, before any fit), or the sequence's status where a frame cannot be fitted.
// A failure after the first fit still writes the rows fitted before it (the report says
// where it stopped). Prints per-fit lines and the summary tables to `log`.
JobStatus RunFitBenchmark(const FitBenchmarkOptions& options, std::ostream& log,
                          std::string* error);

}  // namespace aqs

#endif  // AQS_JOBS_FIT_BENCHMARK_H_
