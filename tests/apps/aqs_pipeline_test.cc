// Runs aqs_pipeline (prepare, pretrain, train) from a flagfile on surface poses of the
// synthetic-muscle bar written as OBJ files, then aqs_train again (resume).

#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "mesh/mesh_io.h"
#include "model/model_io.h"
#include "testing/run_command.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

using testing::AppPath;
using testing::RunCommand;

TEST(AqsPipelineTest, PreparesPretrainsTrainsAndResumes) {
  testing::TempDir dir;
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(5, 0, 0.3, 3);
  std::string error;
  ASSERT_TRUE(WriteObj(dir.File("neutral.obj"), data.model.neutral, &error)) << error;
  std::filesystem::create_directories(dir.File("poses"));
  for (const TrainingPose& pose : data.model.poses) {
    SurfaceMesh surface = data.model.neutral;
    surface.vertices = pose.surface;
    ASSERT_TRUE(WriteObj(dir.File("poses/" + pose.name + ".obj"), surface, &error)) << error;
  }
  std::ofstream(dir.File("run.flags"))
      << "# the bar: 2 x 0.4 x 0.4, its left end (x = 0) fixed\n"
      << "--neutral=" << dir.File("neutral.obj") << "\n"
      << "--poses=" << dir.File("poses") << "\n"
      << "--model=" << dir.File("model") << "\n"
      << "--spacing=0.2\n--lattice=kuhn\n--fixed_box=-1,-1,-1,0.01,1,1\n"
      << "--latent_dim=3\n--hidden=16\n--grid_spacing=0.3\n"
      << "--pretrain_iterations=40\n--train_iterations=4\n--stages=prepare,pretrain,train\n";
  const testing::CommandResult run =
      RunCommand(AppPath("aqs_pipeline") + " --flagfile=" + dir.File("run.flags"));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  for (const char* expected : {"=== prepare\n", "volumetric targets", "=== pretrain\n",
                               "=== train", "train iter     4/4", "pipeline done"}) {
    EXPECT_NE(run.output.find(expected), std::string::npos) << expected << "\n" << run.output;
  }
  ActiveModel model;
  ASSERT_TRUE(LoadModel(dir.File("model"), &model, &error)) << error;
  EXPECT_EQ(model.num_poses(), 5);
  ASSERT_TRUE(model.decoder != nullptr);
  EXPECT_EQ(model.latent_dim(), 3);
  EXPECT_EQ(static_cast<int>(model.states.size()), 5);
  // The CSV log: a header and iterations 0..4.
  std::ifstream log(dir.File("model/train/log.csv"));
  int lines = 0;
  for (std::string line; std::getline(log, line);) ++lines;
  EXPECT_EQ(lines, 6);
  // Training again with the same budget: nothing left; with more, it resumes at 5.
  testing::CommandResult again =
      RunCommand(AppPath("aqs_train") + " --flagfile=" + dir.File("run.flags"));
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("already"), std::string::npos) << again.output;
  again = RunCommand(AppPath("aqs_train") + " --flagfile=" + dir.File("run.flags") +
                     " --train_iterations=6");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("resuming after 4 iterations"), std::string::npos) << again.output;
  EXPECT_NE(again.output.find("train iter     5/6"), std::string::npos) << again.output;
  // The solver layout follows --factor_cache_gb: the bar's small factors fit the default
  // cache (above: one per pose); with no cache, one solver per thread.
  EXPECT_NE(run.output.find("train: one solver and stiffness factor per pose (5 x "),
            std::string::npos) << run.output;
  again = RunCommand(AppPath("aqs_train") + " --flagfile=" + dir.File("run.flags") +
                     " --train_iterations=7 --factor_cache_gb=0");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("train: one solver per thread (the factors of 5 poses, 5 x "),
            std::string::npos) << again.output;
  EXPECT_NE(again.output.find("exceed the factor cache of 0 GB)"), std::string::npos)
      << again.output;
  EXPECT_NE(again.output.find("train iter     7/7"), std::string::npos) << again.output;

  // The whole pipeline again, with one more iteration: prepare and pre-training keep the
  // model (the same inputs and flags), training resumes after its 7 iterations.
  const std::string pipeline = AppPath("aqs_pipeline") + " --flagfile=" + dir.File("run.flags");
  again = RunCommand(pipeline + " --train_iterations=8");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  for (const char* expected :
       {"is the model of these inputs and flags (targets ", "): kept, with its learned state (7 "
        "training iterations)", "pretrain: the model's decoder was pre-trained with these "
        "flags (", "): kept, with 7 training iterations since", "resuming after 7 iterations",
        "train iter     8/8"}) {
    EXPECT_NE(again.output.find(expected), std::string::npos) << expected << "\n" << again.output;
  }
  EXPECT_EQ(again.output.find("volumetric targets by embedded simulation"), std::string::npos)
      << again.output;
  // Other pre-training flags: a trained decoder is not replaced without --restart.
  again = RunCommand(pipeline + " --stages=pretrain --pretrain_iterations=30");
  ASSERT_EQ(again.exit_code, 1) << again.output;
  EXPECT_NE(again.output.find("aqs_pipeline: error: pretrain: the model's decoder was "
                              "pre-trained with other flags (" + dir.File("model") +
                              "/pretrain/key.txt) and trained 8 iterations since, which "
                              "pre-training anew would discard: --restart pre-trains anew"),
            std::string::npos) << again.output;
  // Targets of other options: the trained model is not replaced without --restart.
  again = RunCommand(pipeline + " --attachment_stiffness=50 --stages=prepare,pretrain");
  ASSERT_EQ(again.exit_code, 1) << again.output;
  EXPECT_NE(again.output.find("aqs_pipeline: error: prepare: the model at " + dir.File("model") +
                              " is not the model of these inputs and flags (its targets were "
                              "made with other options; models prepared before 2026-12-06 "
                              "have --inverted_targets=mirror), and preparing it anew would "
                              "discard its learned state (pre-trained, 8 training iterations): "
                              "--restart replaces it"),
            std::string::npos)
      << again.output;
  ASSERT_TRUE(LoadModel(dir.File("model"), &model, &error)) << error;
  EXPECT_EQ(model.checkpoint.iterations, 8) << "untouched";
  // --restart prepares and pre-trains anew.
  again = RunCommand(pipeline + " --attachment_stiffness=50 --stages=prepare,pretrain --restart");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  for (const char* expected : {"volumetric targets by embedded simulation", "wrote model"}) {
    EXPECT_NE(again.output.find(expected), std::string::npos) << expected << "\n" << again.output;
  }
  EXPECT_EQ(again.output.find("kept"), std::string::npos) << again.output;
  // Other pre-training flags on the model not trained since: pre-trained anew.
  again = RunCommand(pipeline + " --attachment_stiffness=50 --stages=prepare,pretrain "
                     "--pretrain_iterations=30");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("kept, with its learned state (0 training iterations)"),
            std::string::npos) << again.output;
  EXPECT_EQ(again.output.find("pre-trained with these flags"), std::string::npos) << again.output;
  // A model not pre-trained (a pipeline stopped before pre-training ended) of other
  // inputs is prepared anew.
  again = RunCommand(pipeline + " --stages=prepare --restart");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  again = RunCommand(pipeline + " --attachment_stiffness=50 --stages=prepare");
  ASSERT_EQ(again.exit_code, 0) << again.output;
  EXPECT_NE(again.output.find("is prepared anew: its targets were made with other options"),
            std::string::npos) << again.output;
}

TEST(AqsPipelineTest, MissingFlagsAndBadStagesFail) {
  testing::CommandResult run = RunCommand(AppPath("aqs_prepare") + " --poses=x --model=y");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.output.find("--neutral, --poses and --model are required"), std::string::npos)
      << run.output;
  run = RunCommand(AppPath("aqs_pipeline") + " --stages=cook --model=x");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.output.find("unknown stage 'cook'"), std::string::npos) << run.output;
  run = RunCommand(AppPath("aqs_train") + " --model=/nonexistent/model");
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.output.find("/nonexistent/model/model.txt"), std::string::npos) << run.output;
  for (const char* bad : {"-1", "nan", "inf"}) {
    run = RunCommand(AppPath("aqs_train") + " --model=/nonexistent/model --factor_cache_gb=" + bad);
    EXPECT_EQ(run.exit_code, 1) << bad;
    EXPECT_NE(run.output.find(std::string("--factor_cache_gb must be finite and >= 0 (is ") +
                              bad + ")"),
              std::string::npos) << run.output;
  }
}

// --helpshort lists every flag an app takes, grouped by the file that defines it: the
// app's own, app_common.cc's and those of each stage's shared flag unit; not glog's or
// gflags' own. It exits with status 1, as gflags' --help does.
TEST(AqsPipelineTest, HelpshortListsEveryStagesFlagsGroupedByFile) {
  testing::CommandResult run = RunCommand(AppPath("aqs_pipeline") + " --helpshort");
  EXPECT_EQ(run.exit_code, 1);
  for (const char* file : {"apps/app_common.cc:", "apps/aqs_pipeline.cc:",
                           "apps/prepare_flags.cc:", "apps/learning_flags.cc:",
                           "apps/evaluate_flags.cc:", "apps/mpi_flags.cc:"}) {
    EXPECT_NE(run.output.find(file), std::string::npos) << file << "\n" << run.output;
  }
  for (const char* flag : {"-model (", "-stages (", "-neutral (", "-latent_dim (",
                           "-train_minutes (", "-test_poses (", "-mpi ("}) {
    EXPECT_NE(run.output.find(flag), std::string::npos) << flag << "\n" << run.output;
  }
  EXPECT_EQ(run.output.find("-logtostderr"), std::string::npos) << run.output;
  run = RunCommand(AppPath("aqs_fit") + " --helpshort");
  EXPECT_EQ(run.exit_code, 1);
  for (const char* expected : {"apps/fit_flags.cc:", "-latent_prior (", "-target ("}) {
    EXPECT_NE(run.output.find(expected), std::string::npos) << expected << "\n" << run.output;
  }
  EXPECT_EQ(run.output.find("-neutral ("), std::string::npos) << run.output;
}

}  // namespace
}  // namespace aqs
