// aqs_pipeline's stage list and its hold of the model's writers' lock
// (jobs/pipeline_stages.h).

#include "jobs/pipeline_stages.h"

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/temp_dir.h"

namespace aqs {
namespace {

TEST(PipelineStagesTest, KeepsTheOrderAndNamesTheBadStage) {
  PipelineStages plan;
  std::string error;
  ASSERT_TRUE(ParsePipelineStages({"prepare", "pretrain", "train", "evaluate"}, &plan, &error));
  EXPECT_EQ(plan.stages.size(), 4u);
  EXPECT_TRUE(plan.WritesModel());
  EXPECT_TRUE(plan.Prepares());
  ASSERT_TRUE(ParsePipelineStages({"pretrain", "evaluate"}, &plan, &error));
  EXPECT_TRUE(plan.WritesModel());
  EXPECT_FALSE(plan.Prepares());
  ASSERT_TRUE(ParsePipelineStages({"evaluate"}, &plan, &error));
  EXPECT_FALSE(plan.WritesModel());

  const std::vector<std::pair<std::vector<std::string>, std::string>> bad = {
      {{}, "--stages: no stage given"},
      {{"prepare", "trian"}, "--stages: unknown stage 'trian' (known: prepare, pretrain, train, "
                             "evaluate)"},
      {{"train", "pretrain"}, "--stages: 'pretrain' after a later stage or twice (the order is "
                              "prepare, pretrain, train, evaluate)"},
      {{"train", "train"}, "--stages: 'train' after a later stage or twice (the order is "
                           "prepare, pretrain, train, evaluate)"}};
  for (const auto& [names, message] : bad) {
    plan.stages = {"left over"};
    EXPECT_FALSE(ParsePipelineStages(names, &plan, &error));
    EXPECT_EQ(error, message);
    EXPECT_TRUE(plan.stages.empty());
  }
}

TEST(PipelineStagesTest, HoldsTheLockOnlyForStagesThatWrite) {
  testing::TempDir dir;
  std::ostringstream log;
  std::string error;
  PipelineStages evaluate_only, prepare_on, train_only;
  ASSERT_TRUE(ParsePipelineStages({"evaluate"}, &evaluate_only, &error));
  ASSERT_TRUE(ParsePipelineStages({"prepare", "pretrain"}, &prepare_on, &error));
  ASSERT_TRUE(ParsePipelineStages({"train"}, &train_only, &error));
  {
    PathLock lock;
    EXPECT_TRUE(LockPipelineModel(evaluate_only, dir.File("m"), &log, &lock, &error));
    EXPECT_FALSE(lock.held());
    EXPECT_TRUE(LockPipelineModel(prepare_on, "", &log, &lock, &error));
    EXPECT_FALSE(lock.held());
  }
  {
    // Training a model whose folder's parent does not exist: nothing to hold (the job
    // says the model is missing).
    PathLock lock;
    EXPECT_TRUE(LockPipelineModel(train_only, dir.File("no/such/m"), &log, &lock, &error));
    EXPECT_FALSE(lock.held());
    EXPECT_FALSE(std::filesystem::exists(dir.File("no")));
  }
  {
    // Preparing makes the parent and holds the lock until released; a trailing slash
    // names the same model.
    PathLock lock;
    EXPECT_TRUE(LockPipelineModel(prepare_on, dir.File("new/m/"), &log, &lock, &error)) << error;
    EXPECT_TRUE(lock.held());
    EXPECT_TRUE(std::filesystem::is_directory(dir.File("new")));
    EXPECT_TRUE(std::filesystem::exists(dir.File("new/m.aqs-lock")));
  }
}

}  // namespace
}  // namespace aqs
