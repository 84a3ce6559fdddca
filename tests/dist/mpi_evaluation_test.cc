// The evaluation's held-out fits over MPI (run by mpirun with 2 ranks): the same
// tables and fitted surfaces as one process, bit for bit, also when a rerun takes the
// fits a stopped run kept.

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "dist/mpi_world.h"
#include "jobs/evaluate_job.h"
#include "mesh/mesh_io.h"
#include "model/model_io.h"
#include "testing/synthetic_muscles.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;
using testing::World;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// The evaluation of a pre-trained bar on `count` held-out poses of it (seed: which),
// single-threaded; rank 0 writes the model and the poses into `dir`.
EvaluateJobOptions BarEvaluation(const Communicator& world, const testing::SharedTempDir& dir,
                                 int count, unsigned seed) {
  EvaluateJobOptions options;
  options.model = dir.File("m");
  options.error_budget = false;
  options.autoencoder.max_iterations = 40;
  options.num_threads = 1;
  options.fit.num_threads = 1;
  options.fit.max_iterations = 10;
  const testing::SyntheticMuscles held_out = testing::MakeSyntheticMuscles(1, count, 0.3, seed);
  for (size_t t = 0; t < held_out.test_surfaces.size(); ++t) {
    options.test_paths.push_back(dir.File("held_out_" + std::to_string(t) + ".obj"));
  }
  std::string error;
  if (world.is_root()) {
    EXPECT_TRUE(SaveModel(options.model, testing::PretrainedBar(3), &error)) << error;
    for (size_t t = 0; t < held_out.test_surfaces.size(); ++t) {
      SurfaceMesh surface = held_out.model.neutral;
      surface.vertices = held_out.test_surfaces[t];
      EXPECT_TRUE(WriteObj(options.test_paths[t], surface, &error)) << error;
    }
  }
  return options;
}

TEST(MpiEvaluationTest, HeldOutFitsGiveTheOutputsOfOneProcess) {
  const Communicator& world = World();
  testing::SharedTempDir dir;
  // Five held-out poses of the same bar (three on rank 0, two on rank 1).
  EvaluateJobOptions options = BarEvaluation(world, dir, 5, 23);
  std::string error;
  world.Barrier();
  std::ostringstream log;
  std::vector<EvaluationRow> one_rows, rows;
  if (world.is_root()) {
    EvaluateJobOptions one = options;
    one.output_directory = dir.File("one");
    EXPECT_TRUE(RunEvaluateJob(one, log, &one_rows, &error)) << error;
  }
  options.output_directory = dir.File("many");
  options.communicator = &world;
  EXPECT_TRUE(RunEvaluateJob(options, log, &rows, &error)) << error;
  if (!world.is_root()) {
    EXPECT_TRUE(rows.empty());  // the other ranks write nothing and return no rows
    EXPECT_FALSE(fs::exists(options.output_directory + "/evaluation.csv"));
    return;
  }
  EXPECT_EQ(rows.size(), one_rows.size());
  const std::string csv = ReadAll(dir.File("many/evaluation.csv"));
  EXPECT_FALSE(csv.empty());
  EXPECT_EQ(csv, ReadAll(dir.File("one/evaluation.csv")));
  int compared = 0;
  for (const auto& entry : fs::directory_iterator(dir.File("one/fitted"))) {
    const std::string name = entry.path().filename();
    EXPECT_EQ(ReadAll(dir.File("many/fitted/" + name)), ReadAll(entry.path())) << name;
    ++compared;
  }
  // Per pose: the target, physics, the auto-encoder and both PCA baselines.
  EXPECT_EQ(compared, 5 * 5);
  std::printf("%d held-out fits over %d ranks: evaluation.csv and %d fitted surfaces identical "
              "to one process\n",
              5, world.size(), compared);
}

// A held-out pose that another machine holds in another version (here rank 1 reads
// another file under the same name, as a stale copy would be): every rank stops, naming
// the pose, before any fit.
TEST(MpiEvaluationTest, AHeldOutPoseUnlikeRankZerosStopsEveryRank) {
  const Communicator& world = World();
  testing::SharedTempDir dir;
  EvaluateJobOptions options = BarEvaluation(world, dir, 3, 31);
  if (world.is_root()) {
    fs::create_directories(dir.File("r1"));
    fs::copy_file(options.test_paths[2], dir.File("r1/held_out_1.obj"));
  }
  world.Barrier();
  if (world.rank() > 0) options.test_paths[1] = dir.File("r1/held_out_1.obj");
  options.output_directory = dir.File("many");
  options.communicator = &world;
  std::ostringstream log;
  std::vector<EvaluationRow> rows;
  std::string error;
  if (world.size() == 1) return;
  EXPECT_FALSE(RunEvaluateJob(options, log, &rows, &error));
  EXPECT_NE(error.find("rank 1: " + dir.File("r1/held_out_1.obj") +
                       ": another surface here than rank 0 read"),
            std::string::npos)
      << error;
  EXPECT_FALSE(fs::exists(dir.File("many/evaluation.csv")));
}

// A distributed evaluation stopped after its fits keeps them (rank 0 writes the other
// ranks' as they arrive); the rerun takes those left and fits the others, and writes
// the outputs of one process.
TEST(MpiEvaluationTest, ARerunTakesTheKeptFitsAndFitsTheRest) {
  const Communicator& world = World();
  testing::SharedTempDir dir;
  EvaluateJobOptions options = BarEvaluation(world, dir, 4, 29);
  options.output_directory = dir.File("many");
  const std::string store = options.output_directory + "/" + kHeldOutFitFolder;
  std::string error;
  if (world.is_root()) {
    // evaluation.md cannot be written (a folder has its name): the run stops after its
    // fits.
    fs::create_directories(options.output_directory + "/evaluation.md");
  }
  world.Barrier();
  std::ostringstream log;
  std::vector<EvaluationRow> one_rows, rows;
  EvaluateJobOptions distributed = options;
  distributed.communicator = &world;
  const bool stopped = RunEvaluateJob(distributed, log, &rows, &error);
  world.Barrier();
  if (world.is_root()) {
    EXPECT_FALSE(stopped);
    EXPECT_NE(error.find("evaluation.md"), std::string::npos) << error;
    for (int t = 0; t < 4; ++t) {
      EXPECT_TRUE(fs::exists(store + "/000" + std::to_string(t) + ".txt")) << t;
    }
    // Two of the four were not kept (one of each rank's).
    fs::remove(store + "/0000.txt");
    fs::remove(store + "/0001.txt");
    fs::remove(options.output_directory + "/evaluation.md");
    EvaluateJobOptions one = options;
    one.output_directory = dir.File("one");
    EXPECT_TRUE(RunEvaluateJob(one, log, &one_rows, &error)) << error;
  }
  world.Barrier();
  std::ostringstream rerun_log;
  EXPECT_TRUE(RunEvaluateJob(distributed, rerun_log, &rows, &error)) << error;
  if (!world.is_root()) return;
  EXPECT_NE(rerun_log.str().find("held-out poses: 2 physics fits in "), std::string::npos)
      << rerun_log.str();
  EXPECT_NE(rerun_log.str().find(", 2 taken from " + store), std::string::npos)
      << rerun_log.str();
  EXPECT_FALSE(fs::exists(store)) << "removed once the tables are written";
  EXPECT_NE(ReadAll(dir.File("many/evaluation.md"))
                .find("2 of the 4 physics fits were a stopped run's"),
            std::string::npos);
  const std::string csv = ReadAll(dir.File("many/evaluation.csv"));
  EXPECT_FALSE(csv.empty());
  EXPECT_EQ(csv, ReadAll(dir.File("one/evaluation.csv")));
  for (const auto& entry : fs::directory_iterator(dir.File("one/fitted"))) {
    const std::string name = entry.path().filename();
    EXPECT_EQ(ReadAll(dir.File("many/fitted/" + name)), ReadAll(entry.path())) << name;
  }
}

}  // namespace
}  // namespace aqs
