// The fit benchmark (jobs/fit_benchmark.h) on a small pre-trained bar and a test set of
// two held-out poses and their scans: what it writes, and how it judges scan fits by
// their own objective.

#include "jobs/fit_benchmark.h"
#include "jobs/fit_benchmark_report.h"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "mesh/mesh_io.h"
#include "model/model_io.h"
#include "testing/fault_kill.h"
#include "testing/file_contents.h"
#include "testing/fit_fixtures.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"
#include "testing/training_fixtures.h"
#include "util/text_split.h"

namespace aqs {
namespace {

// fit_benchmark.csv's rows as column name -> value, keyed by "mix method". The last
// column (start) is quoted and may hold commas.
std::map<std::string, std::map<std::string, std::string>> ReadRows(const std::string& path) {
  std::map<std::string, std::map<std::string, std::string>> rows;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> header = SplitFields(line);
  while (std::getline(in, line)) {
    const size_t quote = line.find('"');
    EXPECT_NE(quote, std::string::npos) << line;
    if (quote == std::string::npos) continue;
    std::vector<std::string> cells = SplitFields(line.substr(0, quote));
    cells.push_back(line.substr(quote + 1, line.rfind('"') - quote - 1));
    EXPECT_EQ(cells.size(), header.size()) << line;
    std::map<std::string, std::string> row;
    for (size_t c = 0; c < cells.size() && c < header.size(); ++c) row[header[c]] = cells[c];
    rows[row["mix"] + " " + row["method"]] = row;
  }
  return rows;
}

// A model (dir/model: the synthetic bar, pre-trained, with its training equilibria) and
// a test set (dir/set) of two held-out poses, each scan its pose's surface vertices in a
// shuffled order.
void WriteModelAndSet(const testing::TempDir& dir) {
  ActiveModel model = testing::PretrainedBarForFits(false);
  ASSERT_TRUE(testing::StoreTrainingEquilibria(&model));
  std::string error;
  ASSERT_TRUE(SaveModel(dir.File("model"), model, &error)) << error;
  const testing::SyntheticMuscles held_out = testing::MakeSyntheticMuscles(1, 2, 0.3, 23);
  std::filesystem::create_directories(dir.File("set/poses"));
  std::filesystem::create_directories(dir.File("set/scans"));
  std::string mixes = "mix,expressions\n";
  for (int t = 0; t < 2; ++t) {
    const std::string name = "mix_00" + std::to_string(t);
    mixes += name + ",held out " + std::to_string(t) + "\n";
    SurfaceMesh pose = model.neutral;
    pose.vertices = held_out.test_surfaces[t];
    ASSERT_TRUE(WriteObj(dir.File("set/poses/" + name + ".obj"), pose, &error)) << error;
    const Eigen::Index n = pose.vertices.cols();
    std::ostringstream ply;
    ply << "ply\nformat ascii 1.0\nelement vertex " << n
        << "\nproperty double x\nproperty double y\nproperty double z\nend_header\n";
    for (Eigen::Index k = 0; k < n; ++k) {
      const Eigen::Vector3d p = pose.vertices.col((k * 7) % n);  // n is not a multiple of 7
      ply << p.x() << " " << p.y() << " " << p.z() << "\n";
    }
    dir.Write("set/scans/" + name + ".ply", ply.str());
  }
  dir.Write("set/mixes.csv", mixes);
}

// The benchmark of dir/model on dir/set (WriteModelAndSet), poses and scans only, into
// dir/out.
FitBenchmarkOptions PosesAndScansOf(const testing::TempDir& dir) {
  FitBenchmarkOptions options;
  options.model = dir.File("model");
  options.test_set = dir.File("set");
  options.output_dir = dir.File("out");
  options.markers = false;
  return options;
}

TEST(FitBenchmarkTest, JudgesScanFitsByTheirOwnObjective) {
  testing::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(WriteModelAndSet(dir));
  std::string error;
  FitBenchmarkOptions options = PosesAndScansOf(dir);
  options.scan_from_pose_fit = true;
  std::ostringstream log;
  ASSERT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kOk) << error << "\n" << log.str();
  const auto rows = ReadRows(dir.File("out/fit_benchmark.csv"));
  SurfaceMesh pose;
  ASSERT_TRUE(ReadObj(dir.File("set/poses/mix_000.obj"), &pose, &error)) << error;
  const int num_vertices = pose.num_vertices();
  for (const std::string mix : {"mix_000", "mix_001"}) {
    ASSERT_TRUE(rows.count(mix + " physics_pose")) << mix;
    ASSERT_TRUE(rows.count(mix + " physics_scan")) << mix;
    ASSERT_TRUE(rows.count(mix + " physics_scan_from_pose")) << mix;
    // Fits of poses are not judged by a scan's objective.
    EXPECT_EQ(rows.at(mix + " physics_pose").at("pose_fit_objective_ratio"), "nan");
    const double scan_ratio =
        std::stod(rows.at(mix + " physics_scan").at("pose_fit_objective_ratio"));
    EXPECT_TRUE(std::isfinite(scan_ratio) && scan_ratio > 0) << scan_ratio;
    // The fit from the fit with correspondence only lowers the scan's objective (its bone
    // prior is centred on its start, where it is zero): that fit's objective is at least
    // its own.
    const auto& from_pose = rows.at(mix + " physics_scan_from_pose");
    EXPECT_GE(std::stod(from_pose.at("pose_fit_objective_ratio")), 1.0 - 1e-9);
    EXPECT_EQ(from_pose.at("start"), "the fit with correspondence");
    EXPECT_TRUE(std::isfinite(std::stod(from_pose.at("mean_error"))));
    // Scans split their error over the vertices they see, along the true surface's normals
    // and across them, and the fit with correspondence's over the same vertices; poses
    // have no scanned region. These scans hold every vertex of their pose: all are seen.
    EXPECT_EQ(rows.at(mix + " physics_pose").at("scanned_vertices"), "0");
    EXPECT_EQ(rows.at(mix + " physics_pose").at("scanned_normal_error"), "nan");
    for (const std::string method : {"physics_scan", "physics_scan_from_pose"}) {
      const auto& row = rows.at(mix + " " + method);
      EXPECT_EQ(std::stoi(row.at("scanned_vertices")), num_vertices) << method;
      for (const std::string who : {"", "pose_fit_"}) {
        const double normal = std::stod(row.at(who + "scanned_normal_error"));
        const double tangential = std::stod(row.at(who + "scanned_tangential_error"));
        EXPECT_TRUE(normal >= 0 && tangential >= 0) << method << " " << who;
        EXPECT_GT(normal + tangential, 0) << method << " " << who;
        EXPECT_EQ(row.at(who + "unscanned_error"), "nan") << method << " " << who;
      }
    }
  }
  const std::string md = testing::ReadAll(dir.File("out/fit_benchmark.md"));
  EXPECT_NE(md.find("| scan from the fit with correspondence (diagnostic) |"), std::string::npos)
      << md;
  EXPECT_NE(md.find("stopped where the scan's objective is larger than at the fit with "
                    "correspondence"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("Over the region the scans see"), std::string::npos) << md;
}

TEST(FitBenchmarkTest, ChecksTheSequenceBeforeAnyFit) {
  // A sequence part without the sequence's files fails before the fits (which would
  // otherwise run, then be lost with the error), naming the folder.
  testing::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(WriteModelAndSet(dir));
  FitBenchmarkOptions options = PosesAndScansOf(dir);
  options.sequence = true;
  std::ostringstream log;
  std::string error;
  EXPECT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find(dir.File("set") + "/sequence/markers"), std::string::npos) << error;
  EXPECT_EQ(log.str().find("physics_pose"), std::string::npos) << "no fit ran:\n" << log.str();
  // With the frames but one truth surface missing, the same, naming that file.
  std::filesystem::create_directories(dir.File("set/sequence/markers"));
  std::filesystem::create_directories(dir.File("set/sequence/truth"));
  for (const std::string frame : {"f000", "f001"}) {
    std::filesystem::copy_file(dir.File("set/poses/mix_000.obj"),
                               dir.File("set/sequence/markers/" + frame + ".obj"));
  }
  std::filesystem::copy_file(dir.File("set/poses/mix_000.obj"),
                             dir.File("set/sequence/truth/f000.obj"));
  log.str("");
  EXPECT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("truth/f001.obj"), std::string::npos) << error;
  EXPECT_EQ(log.str().find("physics_pose"), std::string::npos) << log.str();
}

// The sequence part fits every frame again, into an emptied output_dir/sequence (it
// times them): an earlier run's frames are not resumed, and the log says so.
TEST(FitBenchmarkTest, TheSequencePartSaysItEmptiesItsFolder) {
  testing::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(WriteModelAndSet(dir));
  for (const char* folder : {"set/sequence/markers", "set/sequence/truth"}) {
    std::filesystem::create_directories(dir.File(folder));
    for (const std::string frame : {"f000", "f001"}) {
      std::filesystem::copy_file(dir.File("set/poses/mix_000.obj"),
                                 dir.File(std::string(folder) + "/" + frame + ".obj"));
    }
  }
  FitBenchmarkOptions options = PosesAndScansOf(dir);
  options.poses = options.scans = false;
  options.sequence = true;
  std::ostringstream log;
  std::string error;
  ASSERT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kOk) << error << "\n" << log.str();
  const std::string emptied = "sequence: emptied " + dir.File("out") + "/sequence";
  EXPECT_EQ(log.str().find(emptied), std::string::npos) << log.str();
  EXPECT_TRUE(std::filesystem::exists(dir.File("out/sequence/f001.obj")));
  log.str("");
  ASSERT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kOk) << error << "\n" << log.str();
  EXPECT_NE(log.str().find(emptied), std::string::npos) << log.str();
  EXPECT_NE(log.str().find("fitted 2 frames"), std::string::npos) << log.str();
}

// An input in output_dir/sequence, which the sequence part empties, is refused before
// anything runs (the model or the test set there was deleted after the fits).
TEST(FitBenchmarkTest, RefusesInputsInTheFolderItEmpties) {
  testing::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(WriteModelAndSet(dir));
  std::filesystem::create_directories(dir.File("out"));
  std::filesystem::rename(dir.File("model"), dir.File("out/sequence"));
  FitBenchmarkOptions options = PosesAndScansOf(dir);
  options.model = dir.File("out/sequence");
  options.sequence = true;
  std::ostringstream log;
  std::string error;
  EXPECT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("out/sequence: lies in " + dir.File("out") + "/sequence, which this job "
                       "empties"),
            std::string::npos)
      << error;
  EXPECT_TRUE(std::filesystem::exists(dir.File("out/sequence/model.txt")));
}

TEST(FitBenchmarkTest, KeepsTheRowsFittedBeforeAFailure) {
  testing::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(WriteModelAndSet(dir));
  FitBenchmarkOptions options = PosesAndScansOf(dir);
  std::ostringstream log;
  std::string error;
  // A missing file of a later mix is found before any fit.
  std::filesystem::rename(dir.File("set/scans/mix_001.ply"), dir.File("set/mix_001.ply"));
  EXPECT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("scans/mix_001.ply: missing"), std::string::npos) << error;
  EXPECT_EQ(log.str().find("physics_pose"), std::string::npos) << "no fit ran:\n" << log.str();
  // A damaged one stops the run there, and the rows of the mixes before it are written.
  // A temporary of the tables that a killed run left is removed first, and logged.
  dir.Write("set/scans/mix_001.ply", "ply\nformat ascii 1.0\nelement vertex 2\nend_header\n");
  const std::string stale =
      dir.File("out/fit_benchmark.csv.tmp" + std::to_string(testing::DeadPid()));
  std::ofstream(stale) << "case,method\n";
  log.str("");
  EXPECT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("mix_001.ply"), std::string::npos) << error;
  const auto rows = ReadRows(dir.File("out/fit_benchmark.csv"));
  EXPECT_TRUE(rows.count("mix_000 physics_pose"));
  EXPECT_TRUE(rows.count("mix_000 physics_scan"));
  EXPECT_TRUE(rows.count("mix_001 physics_pose")) << "the pose before the damaged scan";
  EXPECT_FALSE(rows.count("mix_001 physics_scan"));
  const std::string md = testing::ReadAll(dir.File("out/fit_benchmark.md"));
  EXPECT_NE(md.find("**Stopped early** (1 of 2 mixes fitted)"), std::string::npos) << md;
  EXPECT_FALSE(std::filesystem::exists(stale));
  EXPECT_NE(log.str().find("cleanup: "), std::string::npos) << log.str();
  // No frames to fit is refused before anything runs.
  options.sequence_frames = 0;
  EXPECT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("sequence_frames"), std::string::npos) << error;
}

// The markers' ridge PCA chooses its ridge by leave-one-out over at least 3 training
// poses: a model of 2 is refused before any fit (it aborted in a CHECK).
TEST(FitBenchmarkTest, MarkersNeedThreeTrainingPoses) {
  testing::TempDir dir;
  ASSERT_NO_FATAL_FAILURE(WriteModelAndSet(dir));
  testing::SyntheticBarSpec spec;
  spec.num_poses = 2;
  spec.seed = 21;
  spec.pretrain_iterations = 3;
  const ActiveModel model = testing::PretrainedSyntheticBar(spec);
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(SaveModel(dir.File("two"), model, &error)) << error;
  std::filesystem::create_directories(dir.File("set/marker_sets"));
  std::filesystem::create_directories(dir.File("set/markers"));
  dir.Write("set/marker_sets/m3.txt", "0\n1\n2\n");
  for (const std::string mix : {"mix_000", "mix_001"}) {
    std::ostringstream markers;
    for (int v = 0; v < 3; ++v) {
      const Eigen::Vector3d x = model.neutral.vertices.col(v);
      markers << v << " " << x.x() << " " << x.y() << " " << x.z() << "\n";
    }
    dir.Write("set/markers/" + mix + "_m3.txt", markers.str());
  }
  FitBenchmarkOptions options = PosesAndScansOf(dir);
  options.model = dir.File("two");
  options.markers = true;
  options.marker_counts = {3};
  log.str("");
  EXPECT_EQ(RunFitBenchmark(options, log, &error), JobStatus::kBadInput);
  EXPECT_NE(error.find("at least 3 training poses; the model has 2"), std::string::npos) << error;
  EXPECT_EQ(log.str().find("physics_pose"), std::string::npos) << "no fit ran:\n" << log.str();
}

// A row of the benchmark's tables: `method`'s fit of `mix` with `markers` markers (0: none),
// of mean error `mean`.
FitBenchmarkRow TableRow(const std::string& mix, const std::string& method, int markers,
                         double mean) {
  FitBenchmarkRow r;
  r.mix = mix;
  r.method = method;
  r.markers = markers;
  r.mean = mean;
  return r;
}

// The tables count each marker set's mixes against their PCA and neutral rows, and a
// mix without them (rows of a run stopped in between) is left out, not looked up (an
// uncaught std::out_of_range after every fit).
TEST(FitBenchmarkTest, TablesCountTheMixesThatHaveTheirReferences) {
  const std::vector<FitBenchmarkRow> rows = {
      TableRow("mix_000", "neutral", 0, 0.2), TableRow("mix_000", "pca", 20, 0.1),
      TableRow("mix_000", "physics", 20, 0.08), TableRow("mix_001", "neutral", 0, 0.1),
      TableRow("mix_001", "pca", 20, 0.05), TableRow("mix_001", "physics", 20, 0.12),
      TableRow("mix_002", "physics", 20, 0.3),  // its neutral and PCA rows missing
      TableRow("mix_003", "physics_scan", 0, 0.1)};  // a scan without its pose fit
  FitBenchmarkParts parts;
  parts.markers = parts.poses = parts.scans = true;
  parts.marker_counts = {20};
  std::string md;
  ASSERT_NO_THROW(md = FitBenchmarkTables(rows, parts, 100));
  // mix_000 better than PCA, mix_001 worse than PCA and than the neutral (0.12 / 0.1).
  EXPECT_NE(md.find("| 20 | 0.1500 | 0.0750 | 0.1000 | 1 of 2 | 0 | 1 | 1.20 |"),
            std::string::npos)
      << md;
}

// A failed fit (NaN errors, its other figures 0) is left out of every statistic (the
// baselines' means are over the mixes physics fitted) and counted as failed: it counted
// as 0 in the matched points, distances, iterations and work, and "max of mean errors"
// was NaN or not by the order of the mixes.
TEST(FitBenchmarkTest, TablesLeaveFailedFitsOutAndCountThem) {
  auto row = [](const std::string& mix, const std::string& method, int markers, double mean) {
    FitBenchmarkRow r = TableRow(mix, method, markers, mean);
    r.iterations = 12;
    r.factorizations = 42;
    r.matched_fraction = 0.9;
    r.matched_distance = 0.03;
    return r;
  };
  const double nan = std::nan("");
  std::vector<FitBenchmarkRow> rows = {
      row("mix_000", "neutral", 0, 0.2),      row("mix_000", "pca", 20, 0.1),
      row("mix_000", "physics", 20, nan),     row("mix_001", "neutral", 0, 0.1),
      row("mix_001", "pca", 20, 0.05),        row("mix_001", "physics", 20, 0.04),
      row("mix_000", "physics_pose", 0, 0.05), row("mix_001", "physics_pose", 0, 0.05),
      row("mix_000", "physics_scan", 0, nan), row("mix_001", "physics_scan", 0, 0.055)};
  for (FitBenchmarkRow& r : rows) {  // as a failed fit's row is written
    if (!std::isnan(r.mean)) continue;
    r.iterations = r.factorizations = 0;
    r.matched_fraction = r.matched_distance = 0;
  }
  FitBenchmarkParts parts;
  parts.markers = parts.poses = parts.scans = true;
  parts.marker_counts = {20};
  const std::string md = FitBenchmarkTables(rows, parts, 100);
  EXPECT_NE(md.find("| 20 | 0.1000 | 0.0500 | 0.0400 (1 failed) | 1 of 1 | 0 | 0 | 0.40 |"),
            std::string::npos)
      << md;
  EXPECT_NE(md.find("| scan (1 failed) | 0.0550 | 0.0550 |"), std::string::npos) << md;
  EXPECT_NE(md.find("| 12 | 42 |"), std::string::npos) << md;
  EXPECT_NE(md.find("within 1.2x of the fit with correspondence: 1 of 2 (1 failed); worst "
                    "ratio 1.10; matched points 90.0% on average, matched distance 0.0300"),
            std::string::npos)
      << md;
  EXPECT_EQ(md.find("nan"), std::string::npos) << md;
}

}  // namespace
}  // namespace aqs
