// Sequence fits in one process (jobs/fit_sequence.h): independent frames
// (warm_start = false) give each frame the result it gets alone, whatever comes before
// it, and resume like warm-started sequences.

#include "jobs/fit_sequence.h"

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <gtest/gtest.h>

#include "fit/latent_fit.h"
#include "mesh/mesh_io.h"
#include "prepare/volumetric_targets.h"
#include "testing/file_contents.h"
#include "testing/temp_dir.h"
#include "train/pretrain.h"
#include "util/text_split.h"
#include "testing/synthetic_muscles.h"

namespace aqs {
namespace {

using testing::ReadAll;

// frames.csv's rows by frame name, without the frame index (column 0) and the seconds
// (column 10), the only columns that may differ between runs of the same frames.
std::map<std::string, std::vector<std::string>> Rows(const std::string& csv) {
  std::map<std::string, std::vector<std::string>> rows;
  std::ifstream in(csv);
  std::string line;
  std::getline(in, line);
  while (std::getline(in, line)) {
    std::vector<std::string> cells = SplitFields(line);
    EXPECT_GT(cells.size(), 14u) << line;
    if (cells.size() <= 14) continue;
    cells[10] = "";
    cells[0] = "";
    rows[cells[1]] = cells;
  }
  return rows;
}

// A small pre-trained bar with 4 poses and an equilibrium stored per pose (so that fits
// can start from a training pose), and 3 held-out pose targets written as OBJs.
class FitSequenceTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(4, 0, 0.3, 11);
    model_ = new ActiveModel(data.model);
    std::ostringstream log;
    std::string error;
    VolumetricTargetOptions targets;
    targets.num_threads = 1;
    ASSERT_TRUE(MakeVolumetricTargets(targets, model_, log, &error)) << error;
    PretrainOptions pretrain;
    pretrain.spec.latent_dim = 2;
    pretrain.spec.hidden_dims = {8};
    pretrain.spec.activation = Activation::kTanh;
    pretrain.field.node_spacing = 0.35;
    pretrain.max_iterations = 30;
    pretrain.log_every = 0;
    pretrain.num_threads = 1;
    PretrainReport report;
    ASSERT_TRUE(Pretrain(pretrain, model_, &report, log, &error)) << error;
    LatentFitter fitter(*model_, Options().fit);
    for (int p = 0; p < model_->num_poses(); ++p) {
      Eigen::Matrix3Xd state, surface;
      ASSERT_TRUE(fitter.Simulate(model_->latents.col(p), &state, &surface, &error)) << error;
      model_->states.push_back(state);
    }
    const testing::SyntheticMuscles held_out = testing::MakeSyntheticMuscles(1, 3, 0.3, 23);
    for (size_t t = 0; t < held_out.test_surfaces.size(); ++t) {
      SurfaceMesh surface = model_->neutral;
      surface.vertices = held_out.test_surfaces[t];
      ASSERT_TRUE(WriteObj(Target(t), surface, &error)) << error;
    }
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete model_;
  }

  static std::string Target(int t) { return dir_->File("t" + std::to_string(t) + ".obj"); }

  static FitSequenceOptions Options() {
    FitSequenceOptions options;
    options.model = "bar";
    options.fit.num_threads = 1;
    options.fit.max_iterations = 10;
    return options;
  }

  // Fits targets `order` (indices) into output folder `out`.
  static FitSequenceResult Run(const std::vector<int>& order, const std::string& out,
                               bool warm_start) {
    FitSequenceOptions options = Options();
    for (int t : order) options.sequence += Target(t) + ",";
    options.output_dir = dir_->File(out);
    options.warm_start = warm_start;
    std::ostringstream log;
    FitSequenceResult result = RunFitSequence(options, *model_, log);
    EXPECT_EQ(result.status, JobStatus::kOk) << result.message << "\n" << log.str();
    return result;
  }

  static testing::TempDir* dir_;
  static ActiveModel* model_;
};

testing::TempDir* FitSequenceTest::dir_ = nullptr;
ActiveModel* FitSequenceTest::model_ = nullptr;

TEST_F(FitSequenceTest, IndependentFramesDependOnNothingButTheirTarget) {
  Run({0, 1, 2}, "forward", false);
  Run({2, 1}, "backward", false);  // another order, other frames before each
  Run({1}, "alone", false);
  const auto forward = Rows(dir_->File("forward/frames.csv"));
  const auto backward = Rows(dir_->File("backward/frames.csv"));
  const auto alone = Rows(dir_->File("alone/frames.csv"));
  ASSERT_EQ(forward.size(), 3u);
  ASSERT_EQ(backward.size(), 2u);
  ASSERT_EQ(alone.size(), 1u);
  for (const auto& [name, row] : backward) {
    EXPECT_EQ(row, forward.at(name)) << name;
    EXPECT_NE(row[12], "previous") << name << ": every frame chooses its own start";
    EXPECT_EQ(ReadAll(dir_->File("backward/" + name + ".obj")),
              ReadAll(dir_->File("forward/" + name + ".obj")))
        << name;
  }
  EXPECT_EQ(alone.at("t1"), forward.at("t1"));
  EXPECT_EQ(ReadAll(dir_->File("alone/t1.obj")), ReadAll(dir_->File("forward/t1.obj")));
  // Warm starts: the first frame is the same fit, the next ones start from the previous
  // frame's result (which is what makes them depend on the order).
  Run({0, 1, 2}, "warm", true);
  const auto warm = Rows(dir_->File("warm/frames.csv"));
  ASSERT_EQ(warm.size(), 3u);
  EXPECT_EQ(warm.at("t0"), forward.at("t0"));
  EXPECT_EQ(warm.at("t1")[12], "previous");
  EXPECT_EQ(warm.at("t2")[12], "previous");
}

TEST_F(FitSequenceTest, IndependentFramesResumeWithTheSameResults) {
  Run({0, 1, 2}, "whole", false);
  // A kill after frame 0's row was written.
  Run({0}, "resumed", false);
  const FitSequenceResult result = Run({0, 1, 2}, "resumed", false);
  EXPECT_EQ(result.frames_resumed, 1);
  EXPECT_EQ(result.frames_fitted, 2);
  EXPECT_EQ(Rows(dir_->File("resumed/frames.csv")), Rows(dir_->File("whole/frames.csv")));
  EXPECT_EQ(ReadAll(dir_->File("resumed/latents.bin")), ReadAll(dir_->File("whole/latents.bin")));
  for (const char* name : {"t0", "t1", "t2"}) {
    EXPECT_EQ(ReadAll(dir_->File("resumed/" + std::string(name) + ".obj")),
              ReadAll(dir_->File("whole/" + std::string(name) + ".obj")))
        << name;
  }
  // A damaged row (a figure that is not a number) is refused, naming its line, rather
  // than copied into the rewritten frames.csv.
  std::string csv = ReadAll(dir_->File("resumed/frames.csv"));
  const size_t row = csv.find('\n') + 1;  // frame 0's row
  size_t field = row;
  for (int c = 0; c < 6; ++c) field = csv.find(',', field) + 1;  // mean_error
  csv.replace(field, csv.find(',', field) - field, "nan");
  std::ofstream(dir_->File("resumed/frames.csv")) << csv;
  FitSequenceOptions options = Options();
  for (int t : {0, 1, 2}) options.sequence += Target(t) + ",";
  options.output_dir = dir_->File("resumed");
  options.warm_start = false;
  std::ostringstream log;
  const FitSequenceResult damaged = RunFitSequence(options, *model_, log);
  EXPECT_EQ(damaged.status, JobStatus::kBadInput);
  EXPECT_NE(damaged.message.find("frames.csv:2: a number of the row"), std::string::npos)
      << damaged.message;
}

}  // namespace
}  // namespace aqs
