// A sequence fit's outputs (jobs/sequence_outputs.h): a fitted frame's block, its row of
// frames.csv, and what a rerun reads back as done, for frames fitted and frames that
// could not be fitted. The whole sequence job is tested in fit_sequence_test.cc.

#include "jobs/sequence_outputs.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "geometry/rigid_transform.h"
#include "jobs/sequence_frames.h"
#include "testing/fit_fixtures.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

class SequenceOutputsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { model_ = new ActiveModel(testing::PretrainedBarForFits(true)); }
  static void TearDownTestSuite() { delete model_; }

  // A fit result as a fit would leave it: the latent of training pose 1, the base
  // turned and moved, the neutral surface.
  static LatentFitResult AFit() {
    LatentFitResult fit;
    fit.latent = model_->latents.col(1);
    RigidTransform t;
    t.rotation = Eigen::AngleAxisd(0.2, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
    t.translation = Eigen::Vector3d(0.01, -0.02, 0.03);
    fit.bones = {t};
    fit.surface = model_->neutral.vertices;
    fit.used_points = 12;
    fit.matched_fraction = 0.75;
    fit.mean_error = 0.125;
    fit.rms_error = 0.25;
    fit.max_error = 0.5;
    fit.iterations = 4;
    fit.converged = true;
    fit.solve_factorizations = 3;
    fit.jacobians = 2;
    return fit;
  }

  static SequenceFrame Frame(const std::string& name) {
    SequenceFrame frame;
    frame.name = name;
    frame.kind = "markers";
    frame.target.positions.resize(3, 12);
    return frame;
  }

  static ActiveModel* model_;
};
ActiveModel* SequenceOutputsTest::model_ = nullptr;

TEST_F(SequenceOutputsTest, RowsRoundTripAndAFailedFrameIsDoneWithoutItsObj) {
  const ActiveModel& model = *model_;
  const LatentFitResult fit = AFit();
  std::vector<double> block;
  PackFrameBlock(model, fit, model.poses[2].name, 1.5, &block);
  ASSERT_EQ(static_cast<int>(block.size()),
            FrameBlockSize(model.latent_dim(), 1, model.num_surface_vertices()));
  EXPECT_FALSE(BlockFailed(block.data()));
  EXPECT_EQ(Eigen::VectorXd(BlockLatent(model, block.data())), fit.latent);
  EXPECT_EQ(Eigen::Matrix3Xd(BlockSurface(model, block.data())), fit.surface);
  std::vector<double> failed;
  PackFailedFrameBlock(model, fit, "", 0.25, &failed);
  EXPECT_TRUE(BlockFailed(failed.data()));
  EXPECT_TRUE(std::isnan(BlockLatent(model, failed.data())[0]));

  const std::vector<SequenceFrame> frames = {Frame("f0"), Frame("f1"), Frame("f2")};
  const std::string row0 = FrameCsvRow(model, 0, frames[0], block.data());
  const std::string row1 = FrameCsvRow(model, 1, frames[1], failed.data());
  EXPECT_EQ(row0.rfind("0,f0,markers,12,12,0.75,0.125,0.25,0.5,4,", 0), 0u) << row0;
  EXPECT_NE(row0.find("," + model.poses[2].name + ",5,"), std::string::npos) << row0;
  EXPECT_NE(row1.find(",-1,none,"), std::string::npos) << row1;

  testing::TempDir dir;
  dir.Write("frames.csv", SequenceCsvHeader(model) + "\n" + row0 + "\n" + row1 + "\n");
  dir.Write("f0.obj", "v 0 0 0\n");  // frame 0's surface; frame 1, failed, has none
  std::vector<DoneFrame> done;
  std::string error;
  ASSERT_TRUE(ReadFramesDone(dir.File("frames.csv"), dir.path(), model, frames, &done, &error))
      << error;
  ASSERT_EQ(done.size(), 2u);
  EXPECT_EQ(done[0].line, row0);
  EXPECT_FALSE(done[0].failed);
  EXPECT_LT((done[0].latent - fit.latent).cwiseAbs().maxCoeff(), 1e-15);
  ASSERT_EQ(done[0].bones.size(), 1u);
  EXPECT_LT((done[0].bones[0].rotation - fit.bones[0].rotation).cwiseAbs().maxCoeff(), 1e-14);
  EXPECT_LT((done[0].bones[0].translation - fit.bones[0].translation).cwiseAbs().maxCoeff(),
            1e-15);
  EXPECT_TRUE(done[1].failed);

  // Without frame 0's OBJ nothing is done; a row of another frame is another run's.
  ASSERT_TRUE(std::filesystem::remove(dir.File("f0.obj")));
  ASSERT_TRUE(ReadFramesDone(dir.File("frames.csv"), dir.path(), model, frames, &done, &error))
      << error;
  EXPECT_TRUE(done.empty());
  const std::vector<SequenceFrame> others = {Frame("g0"), Frame("g1")};
  EXPECT_FALSE(ReadFramesDone(dir.File("frames.csv"), dir.path(), model, others, &done, &error));
  EXPECT_NE(error.find("frames.csv:2"), std::string::npos) << error;
}

// targets.txt: a frame's line changes with any number of its target, not with its name
// alone; the frames kept are the leading ones whose lines are unchanged, at most those
// done.
TEST_F(SequenceOutputsTest, FramesKeptAreThoseBeforeTheFirstChangedTarget) {
  std::vector<SequenceFrame> frames = {Frame("a"), Frame("b"), Frame("c")};
  for (int f = 0; f < 3; ++f) {
    frames[f].target.positions.setConstant(0.5 * f);
    frames[f].target.vertices = Eigen::Matrix3Xi::Constant(3, 12, f);
  }
  const std::string recorded = SequenceTargetsText(frames);
  EXPECT_EQ(std::count(recorded.begin(), recorded.end(), '\n'), 3);
  EXPECT_EQ(recorded.compare(0, 2, "a "), 0) << recorded;
  EXPECT_EQ(FramesOfSameTargets(recorded, recorded, 3), 3);
  EXPECT_EQ(FramesOfSameTargets(recorded, recorded, 2), 2) << "at most the frames done";
  EXPECT_EQ(FramesOfSameTargets("", recorded, 3), 0);
  EXPECT_EQ(FramesOfSameTargets(recorded.substr(0, recorded.size() - 1), recorded, 3), 2)
      << "a truncated last line";
  std::vector<SequenceFrame> changed = frames;
  changed[1].target.positions(2, 7) += 1e-12;
  EXPECT_EQ(FramesOfSameTargets(recorded, SequenceTargetsText(changed), 3), 1);
  changed = frames;
  changed[2].target.vertices(0, 3) = 5;
  EXPECT_EQ(FramesOfSameTargets(recorded, SequenceTargetsText(changed), 3), 2);
  changed = frames;
  changed[0].landmarks.positions = Eigen::Matrix3Xd::Zero(3, 1);
  EXPECT_EQ(FramesOfSameTargets(recorded, SequenceTargetsText(changed), 3), 0);
  changed = frames;
  changed[0].cloud = Eigen::Matrix3Xd::Ones(3, 2);
  EXPECT_EQ(FramesOfSameTargets(recorded, SequenceTargetsText(changed), 3), 0);
  changed = frames;
  changed[1].kind = "pose";
  EXPECT_EQ(FramesOfSameTargets(recorded, SequenceTargetsText(changed), 3), 1);
}

}  // namespace
}  // namespace aqs
