// Volumetric targets kept as they are made (prepare/target_store.h): a rerun takes the
// poses found for the same model and options, bit for bit, and solves the others; a
// store of other options is emptied.

#include "prepare/target_store.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "prepare/volumetric_targets.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"
#include "util/make_directory.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

class TargetStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    model_ = testing::MakeSyntheticMuscles(3, 0, 0.3, 5).model;
    options_.num_threads = 1;
    options_.store_directory = dir_.File("store");
  }

  // Targets of a fresh copy of the model; *log holds what was said.
  ActiveModel Make(const VolumetricTargetOptions& options, std::string* log) {
    ActiveModel model = model_;
    std::ostringstream out;
    std::string error;
    EXPECT_TRUE(MakeVolumetricTargets(options, &model, out, &error)) << error;
    *log = out.str();
    return model;
  }

  testing::TempDir dir_;
  ActiveModel model_;
  VolumetricTargetOptions options_;
};

TEST_F(TargetStoreTest, ARerunTakesTheStoredPosesAndSolvesTheOthers) {
  std::string log;
  const ActiveModel first = Make(options_, &log);
  EXPECT_EQ(log.find("taken from"), std::string::npos) << log;
  for (int p = 0; p < 3; ++p) {
    EXPECT_TRUE(fs::exists(options_.store_directory + "/000" + std::to_string(p) + ".txt"));
  }
  // A stop before pose 1 was kept: its record is missing.
  fs::remove(options_.store_directory + "/0001.txt");
  const ActiveModel second = Make(options_, &log);
  EXPECT_NE(log.find("2 of 3 poses' targets were taken from " + options_.store_directory),
            std::string::npos)
      << log;
  // The stored poses bit for bit; pose 1, solved again by a solver with another history
  // (its factor is reused across poses), to the solver's tolerance.
  for (int p : {0, 2}) {
    EXPECT_EQ(second.poses[p].target, first.poses[p].target) << p;
    EXPECT_EQ(second.poses[p].embedding_mean_error, first.poses[p].embedding_mean_error) << p;
    EXPECT_EQ(second.poses[p].embedding_max_error, first.poses[p].embedding_max_error) << p;
  }
  EXPECT_LT((second.poses[1].target - first.poses[1].target).cwiseAbs().maxCoeff(), 1e-5);
  Make(options_, &log);
  EXPECT_NE(log.find("3 of 3 poses' targets were taken from"), std::string::npos) << log;
}

TEST_F(TargetStoreTest, OtherOptionsOrAnotherModelEmptyTheStore) {
  std::string log;
  const ActiveModel first = Make(options_, &log);
  VolumetricTargetOptions stiffer = options_;
  stiffer.relative_stiffness = 200.0;
  const ActiveModel other = Make(stiffer, &log);
  EXPECT_EQ(log.find("taken from"), std::string::npos) << log;
  EXPECT_NE(other.poses[0].target, first.poses[0].target);
  // Targets of the other rule for inverted elements are not taken either.
  VolumetricTargetOptions mirror = options_;
  mirror.inverted_targets = InvertedTargets::kMirror;
  EXPECT_NE(TargetStoreKey(mirror, model_), TargetStoreKey(options_, model_));
  // The store now holds the stiffer springs' targets; another model (one pose moved)
  // takes none of them.
  model_.poses[2].surface.col(0).x() += 1e-3;
  Make(stiffer, &log);
  EXPECT_EQ(log.find("taken from"), std::string::npos) << log;
  // Nor does the same model with the neutral's faces in another order (they weigh the
  // attachment springs; the model's own fingerprint has the neutral's vertices only).
  Make(stiffer, &log);
  EXPECT_NE(log.find("taken from"), std::string::npos) << log;
  model_.neutral.triangles.col(0).swap(model_.neutral.triangles.col(1));
  Make(stiffer, &log);
  EXPECT_EQ(log.find("taken from"), std::string::npos) << log;
}

TEST_F(TargetStoreTest, ADamagedRecordIsSolvedAgain) {
  std::string log;
  const ActiveModel first = Make(options_, &log);
  {
    std::ofstream(options_.store_directory + "/0000.bin", std::ios::trunc) << "AQSMAT1\n";
    std::ofstream(options_.store_directory + "/0002.txt", std::ios::trunc) << "mean x\n";
  }
  const ActiveModel second = Make(options_, &log);
  EXPECT_NE(log.find("1 of 3 poses' targets were taken from"), std::string::npos) << log;
  // Solved again, the same bits (a pose's target depends on the pose alone).
  for (int p = 0; p < 3; ++p) EXPECT_EQ(second.poses[p].target, first.poses[p].target) << p;
  {
    // A "failed" line without its message (it threw std::out_of_range).
    std::ofstream(options_.store_directory + "/0001.txt", std::ios::trunc)
        << "mean 0.1\nmax 0.2\nfailed\n";
  }
  const ActiveModel third = Make(options_, &log);
  EXPECT_NE(log.find("2 of 3 poses' targets were taken from"), std::string::npos) << log;
  EXPECT_EQ(third.poses[1].target, first.poses[1].target);
  std::string error;
  ASSERT_TRUE(RemoveDirectory(options_.store_directory, &error)) << error;
  EXPECT_FALSE(fs::exists(options_.store_directory));
  EXPECT_TRUE(RemoveDirectory(options_.store_directory, &error)) << "a missing one is fine";
}

}  // namespace
}  // namespace aqs
