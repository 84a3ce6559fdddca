// The apps that write a model, run as processes: they replace only what is an ActiveQS
// model, refuse a second writer naming the first one's pid, and survive kill -9 (the
// model stays whole, the next run cleans up and resumes at the logged loss).

#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <random>
#include <set>
#include <sstream>
#include <thread>

#include <gtest/gtest.h>

#include "mesh/mesh_io.h"
#include "model/model_io.h"
#include "prepare/volumetric_targets.h"
#include "testing/run_command.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"
#include "testing/training_fixtures.h"
#include "train/pretrain.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;
using testing::AppPath;
using testing::RunCommand;

std::set<std::string> Entries(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.insert(entry.path().filename());
  return names;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// Polls `done` every 10 ms for up to `seconds`.
template <typename Done>
bool WaitFor(Done done, double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return done();
}

// Writes a small pre-trained model of the synthetic bar to `path`.
void WritePretrainedModel(const std::string& path) {
  testing::WritePretrainedSyntheticModel(path, 3, 5, 8, 20);
}

TEST(AqsModelWritingTest, PrepareReplacesOnlyModelsUnlessOverwrite) {
  testing::TempDir dir;
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(2, 0, 0.3, 3);
  std::string error;
  ASSERT_TRUE(WriteObj(dir.File("neutral.obj"), data.model.neutral, &error)) << error;
  fs::create_directories(dir.File("poses"));
  for (const TrainingPose& pose : data.model.poses) {
    SurfaceMesh surface = data.model.neutral;
    surface.vertices = pose.surface;
    ASSERT_TRUE(WriteObj(dir.File("poses/" + pose.name + ".obj"), surface, &error)) << error;
  }
  const auto prepare = [&](const std::string& model, const std::string& more) {
    return RunCommand(AppPath("aqs_prepare") + " --neutral=" + dir.File("neutral.obj") +
                      " --poses=" + dir.File("poses") + " --model=" + model +
                      " --spacing=0.2 --lattice=kuhn --fixed_box=-1,-1,-1,0.01,1,1 --threads=1" +
                      more);
  };
  // A folder that is not a model, with a file and a subfolder: refused, nothing deleted.
  const std::string folder = dir.File("folder");
  fs::create_directories(folder + "/sub");
  dir.Write("folder/notes.txt", "my notes");
  dir.Write("folder/sub/data.txt", "my data");
  testing::CommandResult run = prepare(folder, "");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find(folder + " is a directory that is not an ActiveQS model"),
            std::string::npos) << run.output;
  EXPECT_NE(run.output.find("--overwrite"), std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("volumetric targets"), std::string::npos) << "refused after the work";
  EXPECT_EQ(ReadAll(folder + "/notes.txt"), "my notes");
  EXPECT_EQ(ReadAll(folder + "/sub/data.txt"), "my data");
  EXPECT_EQ(Entries(folder), std::set<std::string>({"notes.txt", "sub"}));
  // A plain file: refused, unchanged.
  const std::string file = dir.Write("file.txt", "text");
  run = prepare(file, "");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_NE(run.output.find(file + " exists and is not an ActiveQS model directory"),
            std::string::npos) << run.output;
  EXPECT_EQ(ReadAll(file), "text");
  EXPECT_EQ(Entries(dir.path()),
            std::set<std::string>({"neutral.obj", "poses", "folder", "file.txt"}));
  // With --overwrite both are replaced; a model is replaced without it.
  run = prepare(folder, " --overwrite");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  run = prepare(file, " --overwrite");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  run = prepare(folder, "");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  ActiveModel model;
  EXPECT_TRUE(LoadModel(folder, &model, &error)) << error;
  EXPECT_TRUE(LoadModel(file, &model, &error)) << error;
  EXPECT_EQ(Entries(dir.path()),
            std::set<std::string>({"neutral.obj", "poses", "folder", "file.txt"}));
}

TEST(AqsModelWritingTest, SecondWriterIsRefusedNamingTheFirstOnesPid) {
  testing::TempDir dir;
  const std::string model = dir.File("model");
  WritePretrainedModel(model);
  const int pid = testing::StartCommand(
      {AppPath("aqs_train"), "--model=" + model, "--train_iterations=100000", "--threads=1"},
      dir.File("first.txt"));
  ASSERT_GT(pid, 0);
  const std::string lock_file = model + ".aqs-lock";
  const bool locked = WaitFor(
      [&] { return ReadAll(lock_file).find("pid " + std::to_string(pid)) != std::string::npos; },
      30);
  const std::string refusal = "model " + model + " is in use by process " +
                              std::to_string(pid) + " (lock file " + lock_file + ")";
  std::vector<testing::CommandResult> second;
  if (locked) {
    for (const std::string& command :
         {AppPath("aqs_train") + " --model=" + model,
          AppPath("aqs_pretrain") + " --model=" + model,
          AppPath("aqs_pipeline") + " --stages=train --model=" + model}) {
      second.push_back(RunCommand(command));
    }
  }
  ::kill(pid, SIGKILL);
  EXPECT_EQ(testing::WaitForCommand(pid), "killed") << ReadAll(dir.File("first.txt"));
  ASSERT_TRUE(locked) << ReadAll(dir.File("first.txt"));
  for (const testing::CommandResult& run : second) {
    EXPECT_EQ(run.exit_code, 1) << run.output;
    EXPECT_NE(run.output.find(refusal), std::string::npos) << run.output;
  }
  // The killed writer's lock is taken over.
  const testing::CommandResult again =
      RunCommand(AppPath("aqs_train") + " --model=" + model + " --train_iterations=1 --threads=1");
  EXPECT_EQ(again.exit_code, 0) << again.output;
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"model", "first.txt"}));
}

// kill -9 of aqs_train at a random moment after a few checkpoints: the model loads, the
// next run cleans up, resumes after the saved iterations at the loss logged for that
// iteration, and the log has each iteration once.
TEST(AqsModelWritingTest, KillNineDuringTrainingThenResumeAtTheLoggedLoss) {
  testing::TempDir dir;
  const std::string model = dir.File("model");
  WritePretrainedModel(model);
  const std::string log_csv = model + "/train/log.csv";
  const int pid = testing::StartCommand(
      {AppPath("aqs_train"), "--model=" + model, "--train_iterations=1000", "--threads=1"},
      dir.File("first.txt"));
  ASSERT_GT(pid, 0);
  const bool started = WaitFor([&] { return testing::TrainingLogRows(log_csv).size() >= 4; }, 60);
  std::mt19937 random(std::random_device{}());
  const int delay_ms = std::uniform_int_distribution<int>(0, 150)(random);
  std::this_thread::sleep_for(std::chrono::milliseconds(delay_ms));
  ::kill(pid, SIGKILL);
  ASSERT_EQ(testing::WaitForCommand(pid), "killed") << ReadAll(dir.File("first.txt"));
  ASSERT_TRUE(started) << ReadAll(dir.File("first.txt"));

  ActiveModel loaded;
  std::string error;
  ASSERT_TRUE(LoadModel(model, &loaded, &error)) << error;
  const int saved = loaded.checkpoint.iterations;
  const std::vector<std::pair<int, double>> rows = testing::TrainingLogRows(log_csv);
  ASSERT_GE(saved, 2);
  ASSERT_GT(static_cast<int>(rows.size()), saved);
  EXPECT_EQ(rows[saved].first, saved);
  EXPECT_EQ(loaded.checkpoint.loss, rows[saved].second);

  const testing::CommandResult run =
      RunCommand(AppPath("aqs_train") + " --model=" + model + " --threads=1 --train_iterations=" +
                 std::to_string(saved + 2));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("resuming after " + std::to_string(saved) + " iterations"),
            std::string::npos) << run.output;
  const size_t at = run.output.find("start loss ");
  ASSERT_NE(at, std::string::npos) << run.output;
  const double start = std::strtod(run.output.c_str() + at + 11, nullptr);
  std::printf("killed %d ms after 4 log rows, %zu rows logged, %d saved; resumed start loss "
              "%.12g, logged %.12g\n",
              delay_ms, rows.size(), saved, start, rows[saved].second);
  EXPECT_NEAR(start, rows[saved].second, 1e-9 * rows[saved].second);
  const std::vector<std::pair<int, double>> after = testing::TrainingLogRows(log_csv);
  ASSERT_EQ(static_cast<int>(after.size()), saved + 3);
  for (int i = 0; i <= saved + 2; ++i) EXPECT_EQ(after[i].first, i);
  // Nothing left over: no lock file, no staging directory, no temporary file.
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"model", "first.txt"}));
  for (const auto& entry : fs::recursive_directory_iterator(model)) {
    const std::string name = entry.path().filename();
    EXPECT_EQ(name.find(".tmp"), std::string::npos) << entry.path();
    EXPECT_EQ(name.find(".aqs-"), std::string::npos) << entry.path();
  }
}

}  // namespace
}  // namespace aqs
