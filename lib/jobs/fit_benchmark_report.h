#ifndef AQS_JOBS_FIT_BENCHMARK_REPORT_H_
#define AQS_JOBS_FIT_BENCHMARK_REPORT_H_

// What aqs_bench_fit writes of its fits (jobs/fit_benchmark.h runs them): the rows of
// fit_benchmark.csv and the summary's tables in fit_benchmark.md.

#include <cmath>
#include <string>
#include <vector>

#include "eval/scan_error_split.h"

namespace aqs {

// One measured fit (or reference: the neutral, PCA) of aqs_bench_fit: a row of
// fit_benchmark.csv.
struct FitBenchmarkRow {
  std::string mix, method;
  int markers = 0;
  double mean = 0, max = 0, seconds = 0;
  int iterations = 0;
  bool converged = true;
  double jaw_degrees = 0;  // the first bone's rotation angle (physics fits)
  double matched_fraction = 0, matched_distance = 0;  // scans
  std::string start;
  int solves = 0, factorizations = 0, jacobians = 0;
  double solve_seconds = 0, jacobian_seconds = 0;
  // With FitBenchmarkOptions' fit.uncertainty (else NaN): the mean predicted standard
  // deviation over the measured vertices, and its Pearson correlation with their errors.
  double predicted_std = std::nan(""), std_error_correlation = std::nan("");
  // Scans, with poses (else NaN): the scan objective (LatentFitter::StartObjective) at the
  // fit with correspondence over this fit's. Below 1: that fit's surface matches the scan
  // better, and this fit stopped in a worse minimum.
  double pose_fit_objective_ratio = std::nan("");
  // Scans: the measured vertices the scan sees (within kScannedSpacings of its sampling
  // spacing of a scan point, on the true pose), and over them the fit's error and, with
  // poses, the fit with correspondence's, split along the true surface's normals (what a
  // scan measures) and across them (eval/scan_error_split.h). NaN where not measured.
  int scanned = 0;
  NormalTangentialError scanned_error{std::nan(""), std::nan(""), std::nan("")};
  NormalTangentialError pose_fit_scanned_error{std::nan(""), std::nan(""), std::nan("")};
  // The same fits' mean error over the measured vertices the scan does not see (NaN if
  // it sees them all).
  double unscanned_error = std::nan(""), pose_fit_unscanned_error = std::nan("");
};

// What a benchmark run fitted, for its tables (FitBenchmarkOptions' parts).
struct FitBenchmarkParts {
  bool markers = false, poses = false, scans = false;
  std::vector<int> marker_counts;  // with markers
  bool uncertainty = false;        // rows carry predicted standard deviations
};

// The summary's tables and sentences (markdown) of `rows`, for the parts run: markers
// (ridge PCA, physics and the neutral per marker count), poses and scans (mean errors,
// times, how scans compare with the fits with correspondence and where their error
// lies), and, with uncertainty, predicted against actual errors. num_measured: the number
// of vertices the errors are measured over.
std::string FitBenchmarkTables(const std::vector<FitBenchmarkRow>& rows,
                               const FitBenchmarkParts& parts, size_t num_measured);

// fit_benchmark.csv: a header line, then one line per row (the start quoted).
std::string FitBenchmarkCsv(const std::vector<FitBenchmarkRow>& rows);

namespace fit_benchmark {

// The median, mean and largest of v (0 if empty), and value as text with `digits`
// decimals.
double Median(std::vector<double> v);
double Mean(const std::vector<double>& v);
double Max(const std::vector<double>& v);
std::string Fixed(double value, int digits);

}  // namespace fit_benchmark
}  // namespace aqs

#endif  // AQS_JOBS_FIT_BENCHMARK_REPORT_H_
