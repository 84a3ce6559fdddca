// aqs_bench_fit: fits a trained model to a test set made by scripts/make_fit_tests.py
// (sparse markers, full poses, scans, a marker sequence) and compares with ridge PCA
// and the neutral face; prints per-fit lines and summary tables, writes
// fit_benchmark.csv and fit_benchmark.md. A benchmark, not a test (docs/fitting.md).
// Exit status: 0 done; 1 bad input.

#include <algorithm>
#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "fit_flags.h"
#include "jobs/fit_benchmark.h"
#include "util/line_reader.h"
#include "util/text_split.h"
#include "util/vertex_ranges.h"

DECLARE_string(model);
DEFINE_string(test_set, "", "The test-set folder (scripts/make_fit_tests.py --out).");
DEFINE_string(output_dir, "", "Where fit_benchmark.csv and fit_benchmark.md go.");
DEFINE_string(error_vertices, "0:9409", "Surface vertices measured (the ICT face region).");
DEFINE_string(marker_counts, "20,60", "Marker sets to fit (markers/mix_NNN_mK.txt).");
DEFINE_string(parts, "markers,poses,scans,sequence", "What to run: markers, poses, scans, sequence.");
DEFINE_int32(max_mixes, -1, "Only the first N mixes (< 0: all).");
DEFINE_int32(sequence_frames, -1, "Only the first N sequence frames (< 0: all).");
DEFINE_bool(scan_from_pose_fit, false, "Diagnostic, with poses and scans: also fit each scan "
            "from the fit with correspondence's latent and bones (physics_scan_from_pose).");
DEFINE_bool(uncertainty, false, "Also estimate each physics fit's uncertainty (aqs_fit "
            "--output_uncertainty) and report how it compares with the fit's error.");

int main(int argc, char** argv) {
  aqs::InitApp("Benchmark fits against ridge PCA and the neutral.\n"
               "  aqs_bench_fit --model=MODEL --test_set=DIR --output_dir=OUT",
               &argc, &argv);
  aqs::FitBenchmarkOptions options;
  options.model = FLAGS_model;
  options.test_set = FLAGS_test_set;
  options.output_dir = FLAGS_output_dir;
  options.max_mixes = FLAGS_max_mixes;
  options.sequence_frames = FLAGS_sequence_frames;
  options.temporal_prior = aqs::TemporalPriorFlag();
  std::string error;
  if (!aqs::FitOptionsFromFlags(&options.fit, &options.points, &options.start, &error)) {
    aqs::PrintError(error);
    return 1;
  }
  if (!FLAGS_error_vertices.empty() &&
      !aqs::ParseVertexRanges(FLAGS_error_vertices, &options.error_vertices, &error)) {
    aqs::PrintError("--error_vertices: " + error);
    return 1;
  }
  options.fit.uncertainty = FLAGS_uncertainty;
  options.scan_from_pose_fit = FLAGS_scan_from_pose_fit;
  options.marker_counts.clear();
  for (const std::string& k : aqs::SplitList(FLAGS_marker_counts)) {
    int count = 0;
    if (!aqs::ParseInt(k, &count)) {
      aqs::PrintError("--marker_counts: '" + k + "' is not a whole number");
      return 1;
    }
    if (std::count(options.marker_counts.begin(), options.marker_counts.end(), count) > 0) {
      aqs::PrintError("--marker_counts: " + k + " is given twice");
      return 1;
    }
    options.marker_counts.push_back(count);
  }
  const std::vector<std::string> parts = aqs::SplitList(FLAGS_parts);
  if (parts.empty()) {
    aqs::PrintError("--parts: no part given (markers, poses, scans, sequence)");
    return 1;
  }
  options.markers = options.poses = options.scans = options.sequence = false;
  for (const std::string& part : parts) {
    if (part == "markers") {
      options.markers = true;
    } else if (part == "poses") {
      options.poses = true;
    } else if (part == "scans") {
      options.scans = true;
    } else if (part == "sequence") {
      options.sequence = true;
    } else {
      aqs::PrintError("--parts: unknown part '" + part + "' (markers, poses, scans, sequence)");
      return 1;
    }
  }
  aqs::FlagNames flags = aqs::FitFlagNames();
  flags.insert(flags.end(), {{"model", "--model"},
                             {"test_set", "--test_set"},
                             {"output_dir", "--output_dir"},
                             {"marker_counts", "--marker_counts"},
                             {"sequence_frames", "--sequence_frames"}});
  if (!options.Validate(&error)) {
    aqs::PrintError(aqs::FlagError(error, flags));
    return 1;
  }
  const aqs::JobStatus status = aqs::RunFitBenchmark(options, std::cout, &error);
  // A benchmark exits 1 for bad input and for a failed case (docs/apps.md, "Exit
  // status"), also when a sequence frame did not converge.
  return aqs::FinishJob(status == aqs::JobStatus::kOk ? status : aqs::JobStatus::kBadInput,
                        error, flags);
}
