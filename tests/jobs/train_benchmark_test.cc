// The training benchmark as a library call (jobs/train_benchmark.h): its options, the
// poses it keeps, its unit, and a run that prints a row per mode.

#include "jobs/train_benchmark.h"

#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "model/model_io.h"
#include "testing/temp_dir.h"
#include "testing/training_fixtures.h"

namespace aqs {
namespace {

TEST(TrainBenchmarkTest, OptionsNameTheBadField) {
  TrainBenchmarkOptions options;
  std::string error;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error, "model is required");
  options.model = "m";
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.modes = {"per_pose", "fast"};
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error, "modes: 'fast' is not per_pose, stored or shared");
  options.modes = {"stored"};
  options.train.num_threads = 0;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("train.num_threads", 0), 0u) << error;
}

TEST(TrainBenchmarkTest, KeepsSpreadPosesUnitsAndARowPerMode) {
  testing::SyntheticBarSpec spec;
  spec.num_poses = 6;
  ActiveModel model = testing::PretrainedSyntheticBar(spec);
  ActiveModel kept = model;
  KeepSpreadPoses(3, &kept);  // poses 0, 2, 4
  ASSERT_EQ(kept.num_poses(), 3);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(kept.poses[i].name, model.poses[2 * i].name);
    EXPECT_EQ(Eigen::VectorXd(kept.latents.col(i)), Eigen::VectorXd(model.latents.col(2 * i)));
  }

  const FactorizationUnit unit = MeasureFactorizationUnit(model);
  EXPECT_GT(unit.seconds, 0.0);
  EXPECT_GT(unit.seconds_one_thread, 0.0);
  EXPECT_GT(unit.dofs, 0);
  EXPECT_GE(unit.factor_nonzeros, unit.stiffness_nonzeros);
  EXPECT_GT(unit.stored_bytes, 0.0);
  EXPECT_LT(unit.stored_bytes, unit.factor_bytes);
  EXPECT_GE(unit.restored_cg_iterations, 1);  // single precision costs CG a few
  EXPECT_LE(unit.restored_cg_iterations, 10);

  testing::TempDir dir;
  std::string error;
  ASSERT_TRUE(SaveModel(dir.File("m"), model, &error)) << error;
  TrainBenchmarkOptions options;
  options.model = dir.File("m");
  options.iterations = 1;
  options.modes = {"per_pose", "shared"};
  options.max_poses = 4;
  std::ostringstream out;
  ASSERT_EQ(RunTrainBenchmark(options, out, &error), JobStatus::kOk) << error;
  const std::string text = out.str();
  EXPECT_NE(text.find("poses kept (4 of 6):"), std::string::npos) << text;
  EXPECT_NE(text.find("\nper_pose       1 "), std::string::npos) << text;
  EXPECT_NE(text.find("\nshared         1 "), std::string::npos) << text;
}

}  // namespace
}  // namespace aqs
