// The apps over MPI, run by mpirun from this (ordinary) test: aqs_train on 2 ranks and
// resumed on 1, spare ranks, a rank killed with SIGKILL mid-run (the job stops, the
// checkpoint resumes), aqs_evaluate's and aqs_fit --sequence's outputs against one
// process, aqs_pipeline (every stage's per-pose work shared), and bad input stopping every
// rank with one message.

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "mesh/mesh_io.h"
#include "model/model_io.h"
#include "prepare/volumetric_targets.h"
#include "testing/file_contents.h"
#include "testing/run_command.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"
#include "testing/training_fixtures.h"
#include "train/pretrain.h"
#include "util/text_split.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;
using testing::AppPath;
using testing::CommandResult;
using testing::RunCommand;

// `command` run by mpirun on `ranks` processes of this machine (as root too, shared
// memory only), stopped after 240 s (exit code 124: a hang).
CommandResult MpiRun(int ranks, const std::string& command) {
  return RunCommand(
      "OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl=self,vader "
      "OPENBLAS_NUM_THREADS=1 timeout -k 10 240 " AQS_MPIEXEC " " AQS_MPIEXEC_NUMPROC_FLAG " " +
      std::to_string(ranks) + " " AQS_MPIEXEC_PREFLAGS " " + command);
}

using testing::ReadAll;

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

// The start loss aqs_train prints ("start loss X", 12 significant digits), or -1.
double StartLoss(const std::string& output) {
  const size_t at = output.find("start loss ");
  return at == std::string::npos ? -1.0 : std::atof(output.c_str() + at + 11);
}

int SavedIterations(const std::string& path) {
  ActiveModel model;
  std::string error;
  EXPECT_TRUE(LoadModel(path, &model, &error)) << error;
  return model.checkpoint.iterations;
}

// A small pre-trained model of the synthetic bar with `poses` poses at `path`.
void WritePretrainedModel(const std::string& path, int poses) {
  testing::WritePretrainedSyntheticModel(path, poses, 5, 8, 20);
}

TEST(MpiAppsTest, TrainsOnTwoRanksAndResumesInOneProcess) {
  testing::TempDir dir;
  const std::string model = dir.File("m");
  WritePretrainedModel(model, 3);
  CommandResult run = MpiRun(2, AppPath("aqs_train") + " --model=" + model + " --train_iterations=3");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(Count(run.output, "train: 3 poses"), 1) << run.output;  // rank 0 logs alone
  EXPECT_NE(run.output.find("per rank: 2 1"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("train iter     3/3"), std::string::npos) << run.output;
  auto rows = testing::TrainingLogRows(model + "/train/log.csv");
  ASSERT_EQ(rows.size(), 4u);
  EXPECT_EQ(SavedIterations(model), 3);
  run = RunCommand(AppPath("aqs_train") + " --model=" + model + " --train_iterations=4 --threads=1");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("resuming after 3 iterations"), std::string::npos) << run.output;
  EXPECT_NEAR(StartLoss(run.output), rows[3].second, 1e-10 * rows[3].second) << run.output;
  EXPECT_EQ(testing::TrainingLogRows(model + "/train/log.csv").size(), 5u);
}

// Ranks given other flags (a flagfile that differs between machines) stop at once, all
// of them, with one message naming the flag: one rank refusing a flag the others took
// had left them waiting for each other (a hang), and another value trained another
// problem on that rank without a word.
TEST(MpiAppsTest, RanksGivenOtherFlagsStopNamingTheFlag) {
  testing::TempDir dir;
  const std::string model = dir.File("m");
  WritePretrainedModel(model, 2);
  const std::string train =
      AppPath("aqs_train") + " --model=" + model + " --train_iterations=1";
  for (const std::string other : {"--threads=0", "--energy_regularization=50"}) {
    SCOPED_TRACE(other);
    const CommandResult run =
        MpiRun(1, train + " : " AQS_MPIEXEC_NUMPROC_FLAG " 1 " + train + " " + other);
    EXPECT_NE(run.exit_code, 0) << run.output;
    EXPECT_NE(run.exit_code, 124) << "a hang: " << run.output;
    EXPECT_NE(run.output.find("aqs_train: error: rank 1: " + other +
                              " differs from rank 0's: every rank must be given the same flags"),
              std::string::npos)
        << run.output;
    EXPECT_EQ(SavedIterations(model), 0);
  }
}

TEST(MpiAppsTest, MoreRanksThanPosesLeavesTheSpareRanksIdle) {
  testing::TempDir dir;
  const std::string model = dir.File("m");
  WritePretrainedModel(model, 2);
  const CommandResult run =
      MpiRun(3, AppPath("aqs_train") + " --model=" + model + " --train_iterations=2");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("per rank: 1 1 0 (rank 2 has no pose and stays idle)"),
            std::string::npos) << run.output;
  EXPECT_EQ(SavedIterations(model), 2);
}

// kill -9 of rank 1 while it solves its poses: mpirun ends the whole job (no hang), the
// model holds rank 0's last checkpoint, and training resumes there at the logged loss,
// on 2 ranks; then rank 0 killed while writing a checkpoint, resumed by one process.
TEST(MpiAppsTest, AKilledRankStopsTheJobAndItsCheckpointResumes) {
  testing::TempDir dir;
  const std::string model = dir.File("m");
  WritePretrainedModel(model, 3);
  CommandResult run = MpiRun(2, std::string(AQS_MPI_KILL_AT) + " objective:solved 12 1 " + model + " 60");
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.exit_code, 124) << "mpirun hung: " << run.output;
  EXPECT_NE(run.output.find("signal 9"), std::string::npos) << run.output;
  int saved = SavedIterations(model);
  std::printf("rank 1 killed at its 13th evaluation: checkpoint of iteration %d\n", saved);
  ASSERT_GE(saved, 1) << run.output;
  auto rows = testing::TrainingLogRows(model + "/train/log.csv");
  ASSERT_GT(static_cast<int>(rows.size()), saved);
  run = MpiRun(2, AppPath("aqs_train") + " --model=" + model +
                      " --train_iterations=" + std::to_string(saved + 2));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("resuming after " + std::to_string(saved) + " iterations"),
            std::string::npos) << run.output;
  EXPECT_NEAR(StartLoss(run.output), rows[saved].second, 1e-10 * rows[saved].second) << run.output;
  rows = testing::TrainingLogRows(model + "/train/log.csv");
  ASSERT_EQ(static_cast<int>(rows.size()), saved + 3);
  for (int i = 0; i <= saved + 2; ++i) EXPECT_EQ(rows[i].first, i);

  // Rank 0 killed inside its second checkpoint of this run, between writing the new
  // learned state and putting it in place.
  const int before = saved + 2;
  run = MpiRun(2, std::string(AQS_MPI_KILL_AT) + " staging:filled 1 0 " + model + " 60");
  EXPECT_NE(run.exit_code, 0) << run.output;
  EXPECT_NE(run.exit_code, 124) << "mpirun hung: " << run.output;
  saved = SavedIterations(model);
  EXPECT_EQ(saved, before + 1) << run.output;
  rows = testing::TrainingLogRows(model + "/train/log.csv");
  ASSERT_GT(static_cast<int>(rows.size()), saved);
  run = RunCommand(AppPath("aqs_train") + " --model=" + model + " --threads=1 --train_iterations=" +
                   std::to_string(saved + 1));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("cleanup: "), std::string::npos) << run.output;  // the staging dir
  EXPECT_NEAR(StartLoss(run.output), rows[saved].second, 1e-10 * rows[saved].second) << run.output;
  EXPECT_EQ(static_cast<int>(testing::TrainingLogRows(model + "/train/log.csv").size()), saved + 2);
}

TEST(MpiAppsTest, EvaluateOnTwoRanksWritesWhatOneProcessWrites) {
  testing::TempDir dir;
  const std::string model = dir.File("m");
  WritePretrainedModel(model, 3);
  const testing::SyntheticMuscles held_out = testing::MakeSyntheticMuscles(1, 3, 0.3, 9);
  std::string list, error;
  for (size_t t = 0; t < held_out.test_surfaces.size(); ++t) {
    SurfaceMesh surface = held_out.model.neutral;
    surface.vertices = held_out.test_surfaces[t];
    const std::string path = dir.File("held_" + std::to_string(t) + ".obj");
    ASSERT_TRUE(WriteObj(path, surface, &error)) << error;
    list += (list.empty() ? "" : ",") + path;
  }
  const std::string flags = " --model=" + model + " --test_poses=" + list +
                            " --baseline_iterations=20 --fit_iterations=5 --error_budget=false "
                            "--report=false --threads=1";
  CommandResult run = RunCommand("OPENBLAS_NUM_THREADS=1 " + AppPath("aqs_evaluate") + flags +
                                 " --output_dir=" + dir.File("one"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  run = MpiRun(2, AppPath("aqs_evaluate") + flags + " --output_dir=" + dir.File("many"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("3 physics fits in"), std::string::npos) << run.output;
  EXPECT_EQ(Count(run.output, "wrote "), 1) << run.output;
  EXPECT_EQ(ReadAll(dir.File("many/evaluation.csv")), ReadAll(dir.File("one/evaluation.csv")));
  EXPECT_EQ(ReadAll(dir.File("many/evaluation.md")), ReadAll(dir.File("one/evaluation.md")));
}


TEST(MpiAppsTest, FitSequenceOnTwoRanksWritesWhatOneProcessWrites) {
  testing::TempDir dir;
  const std::string model = dir.File("m");
  WritePretrainedModel(model, 3);
  const testing::SyntheticMuscles held_out = testing::MakeSyntheticMuscles(1, 3, 0.3, 9);
  std::string error;
  fs::create_directories(dir.File("seq"));
  for (size_t t = 0; t < held_out.test_surfaces.size(); ++t) {
    SurfaceMesh surface = held_out.model.neutral;
    surface.vertices = held_out.test_surfaces[t];
    ASSERT_TRUE(WriteObj(dir.File("seq/f" + std::to_string(t) + ".obj"), surface, &error)) << error;
  }
  const std::string fit = AppPath("aqs_fit") + " --model=" + model + " --sequence=" +
                          dir.File("seq") + " --fit_iterations=10";
  const std::string flags = " --sequence_warm_start=false --threads=1";
  CommandResult run = RunCommand("OPENBLAS_NUM_THREADS=1 " + fit + flags + " --output_dir=" +
                                 dir.File("one"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  run = MpiRun(2, fit + flags + " --output_dir=" + dir.File("many"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(Count(run.output, "independent frames, shared among 2 ranks"), 1) << run.output;
  EXPECT_EQ(Count(run.output, "fitted 3 frames"), 1) << run.output;
  const std::string csv = testing::FramesCsvWithoutSeconds(dir.File("many/frames.csv"));
  EXPECT_EQ(Count(csv, "\n"), 4) << csv;
  EXPECT_EQ(csv, testing::FramesCsvWithoutSeconds(dir.File("one/frames.csv")));
  EXPECT_EQ(ReadAll(dir.File("many/latents.bin")), ReadAll(dir.File("one/latents.bin")));
  for (int t = 0; t < 3; ++t) {
    const std::string name = "/f" + std::to_string(t) + ".obj";
    EXPECT_EQ(ReadAll(dir.File("many") + name), ReadAll(dir.File("one") + name)) << name;
  }
  // Warm-started sequences and single targets are not shared: exit 1, one message.
  run = MpiRun(2, fit + " --output_dir=" + dir.File("warm"));
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_EQ(Count(run.output, "aqs_fit: error: a warm-started sequence "
                              "(--sequence_warm_start, the default)"), 1)
      << run.output;
  EXPECT_NE(run.output.find("give --sequence_warm_start=false"), std::string::npos) << run.output;
  run = MpiRun(2, AppPath("aqs_fit") + " --model=" + model + " --target=" +
                      dir.File("seq/f0.obj") + " --output=" + dir.File("single.obj"));
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_EQ(Count(run.output, "aqs_fit: error: one --target is fitted by one process"), 1)
      << run.output;
}

// The synthetic bar's neutral and pose surfaces as dir/neutral.obj and dir/poses/*.obj.
testing::SyntheticMuscles WriteSyntheticSurfaces(const testing::TempDir& dir) {
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(3, 2, 0.3, 3);
  std::string error;
  EXPECT_TRUE(WriteObj(dir.File("neutral.obj"), data.model.neutral, &error)) << error;
  fs::create_directories(dir.File("poses"));
  for (const TrainingPose& pose : data.model.poses) {
    SurfaceMesh surface = data.model.neutral;
    surface.vertices = pose.surface;
    EXPECT_TRUE(WriteObj(dir.File("poses/" + pose.name + ".obj"), surface, &error)) << error;
  }
  return data;
}

TEST(MpiAppsTest, PrepareAndPretrainShareTheirPosesAmongTheRanks) {
  testing::TempDir dir;
  WriteSyntheticSurfaces(dir);
  const std::string prepare =
      AppPath("aqs_prepare") + " --neutral=" + dir.File("neutral.obj") + " --poses=" +
      dir.File("poses") + " --spacing=0.2 --lattice=kuhn --fixed_box=-1,-1,-1,0.01,1,1";
  CommandResult run = MpiRun(2, prepare + " --model=" + dir.File("model"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(Count(run.output, "3 poses shared among 2 ranks"), 1) << run.output;
  EXPECT_EQ(Count(run.output, "wrote model"), 1) << run.output;
  ActiveModel model;
  std::string error;
  ASSERT_TRUE(LoadModel(dir.File("model"), &model, &error)) << error;
  EXPECT_FALSE(model.target_key.empty());  // every pose converged
  for (const TrainingPose& pose : model.poses) {
    EXPECT_EQ(pose.target.cols(), model.mesh.num_tets()) << pose.name;
  }
  // Pre-training on 2 ranks: rank 0's iterations, every pose's simulation shared; the
  // same model as one process with one thread writes.
  fs::copy(dir.File("model"), dir.File("alone"), fs::copy_options::recursive);
  const std::string pretrain = " --latent_dim=2 --hidden=8 --grid_spacing=0.3 "
                               "--pretrain_iterations=20";
  run = MpiRun(2, AppPath("aqs_pretrain") + " --model=" + dir.File("model") + pretrain);
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_EQ(Count(run.output, "(shared among 2 ranks)"), 1) << run.output;
  run = RunCommand("OPENBLAS_NUM_THREADS=1 " + AppPath("aqs_pretrain") + " --model=" +
                   dir.File("alone") + pretrain + " --threads=1");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const char* name : {"/learned/decoder.txt", "/learned/latents.bin",
                           "/learned/states/0000.bin", "/learned/states/0001.bin",
                           "/learned/states/0002.bin", "/pretrain/surface_errors.bin"}) {
    EXPECT_EQ(ReadAll(dir.File("model") + name), ReadAll(dir.File("alone") + name)) << name;
    EXPECT_FALSE(ReadAll(dir.File("model") + name).empty()) << name;
  }
  // Bad input on rank 0 stops both ranks with one message.
  run = MpiRun(2, prepare + " --model=" + dir.File("model2") + " --spacing=-1");
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_EQ(Count(run.output, "aqs_prepare: error:"), 1) << run.output;
}

TEST(MpiAppsTest, PipelineRunsEveryStageOverTheRanks) {
  testing::TempDir dir;
  const testing::SyntheticMuscles data = WriteSyntheticSurfaces(dir);
  SurfaceMesh held = data.model.neutral;
  held.vertices = data.test_surfaces[0];
  std::string error;
  ASSERT_TRUE(WriteObj(dir.File("held.obj"), held, &error)) << error;
  const CommandResult run = MpiRun(
      2, AppPath("aqs_pipeline") + " --neutral=" + dir.File("neutral.obj") + " --poses=" +
             dir.File("poses") + " --model=" + dir.File("model") +
             " --spacing=0.2 --lattice=kuhn --fixed_box=-1,-1,-1,0.01,1,1 --latent_dim=2 "
             "--hidden=8 --grid_spacing=0.3 --pretrain_iterations=20 --train_iterations=2 "
             "--latent_refit_iterations=2 --test_poses=" + dir.File("held.obj") +
             " --output_dir=" + dir.File("eval") +
             " --baseline_iterations=20 --fit_iterations=5 --report=false");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  // The latent refit before training (as the demo and full-face configs have it) is
  // shared by the ranks and logged once.
  EXPECT_EQ(Count(run.output, "latent refit: loss"), 1) << run.output;
  // Prepare's targets and pre-training's simulation of every pose are shared too.
  EXPECT_EQ(Count(run.output, "poses shared among 2 ranks"), 1) << run.output;
  EXPECT_EQ(Count(run.output, "pre-trained poses simulated in"), 1) << run.output;
  EXPECT_EQ(Count(run.output, "(shared among 2 ranks)"), 1) << run.output;
  for (const char* stage : {"=== prepare done", "=== pretrain done", "=== train done",
                            "=== evaluate done", "pipeline done"}) {
    EXPECT_EQ(Count(run.output, stage), 1) << stage << "\n" << run.output;
  }
  EXPECT_EQ(SavedIterations(dir.File("model")), 2);
  EXPECT_TRUE(fs::exists(dir.File("eval/evaluation.csv")));
}

TEST(MpiAppsTest, BadInputStopsEveryRankWithOneMessage) {
  testing::TempDir dir;
  CommandResult run = MpiRun(2, AppPath("aqs_train") + " --model=" + dir.File("missing/model"));
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_EQ(Count(run.output, "aqs_train: error: "), 1) << run.output;
  EXPECT_NE(run.output.find(dir.File("missing/model")), std::string::npos) << run.output;
  // A model that is not pre-trained: every rank stops, rank 0 says why.
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(2, 0, 0.3, 5);
  std::string error;
  ASSERT_TRUE(SaveModel(dir.File("raw"), data.model, &error)) << error;
  run = MpiRun(2, AppPath("aqs_train") + " --model=" + dir.File("raw"));
  EXPECT_EQ(run.exit_code, 1) << run.output;
  EXPECT_EQ(Count(run.output, "aqs_train: error: "), 1) << run.output;
  EXPECT_NE(run.output.find("pre-train it first"), std::string::npos) << run.output;
}

}  // namespace
}  // namespace aqs
