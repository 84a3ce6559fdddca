// Sequence fits over MPI (run by mpirun with 2 ranks): independent frames shared among
// the ranks give the outputs of one process (frames.csv up to its seconds column,
// latents.bin and every OBJ byte for byte); a partial run resumes with the other number
// of ranks; bad input stops every rank.

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "dist/mpi_world.h"
#include "fit/latent_fit.h"
#include "jobs/fit_sequence.h"
#include "mesh/mesh_io.h"
#include "model/model_io.h"
#include "testing/file_contents.h"
#include "testing/synthetic_muscles.h"
#include "util/text_split.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;
using testing::World;

constexpr int kFrames = 5;  // rounds of 2 frames, the last with rank 1 idle

using testing::ReadAll;


// Rank 0: whether folder `a` holds the outputs of folder `b` (but the seconds).
void ExpectSameOutputs(const std::string& a, const std::string& b) {
  const std::string csv = testing::FramesCsvWithoutSeconds(a + "/frames.csv");
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), kFrames + 1) << csv;
  EXPECT_EQ(csv, testing::FramesCsvWithoutSeconds(b + "/frames.csv"));
  EXPECT_FALSE(ReadAll(a + "/latents.bin").empty());
  EXPECT_EQ(ReadAll(a + "/latents.bin"), ReadAll(b + "/latents.bin"));
  for (int t = 0; t < kFrames; ++t) {
    const std::string name = "/t" + std::to_string(t) + ".obj";
    EXPECT_FALSE(ReadAll(a + name).empty()) << a + name;
    EXPECT_EQ(ReadAll(a + name), ReadAll(b + name)) << name;
  }
}

class MpiSequenceTest : public ::testing::Test {
 protected:
  // The pre-trained bar with an equilibrium per pose (fits may start from a training
  // pose) and kFrames held-out pose targets, written by rank 0.
  void SetUp() override {
    dir_ = std::make_unique<testing::SharedTempDir>();
    options_.model = dir_->File("m");
    options_.fit.num_threads = 1;
    options_.fit.max_iterations = 10;
    options_.warm_start = false;
    for (int t = 0; t < kFrames; ++t) options_.sequence += dir_->File("t" + std::to_string(t) + ".obj,");
    if (World().is_root()) {
      ActiveModel model = testing::PretrainedBar(3);
      std::string error;
      LatentFitter fitter(model, options_.fit);
      for (int p = 0; p < model.num_poses(); ++p) {
        Eigen::Matrix3Xd state, surface;
        EXPECT_TRUE(fitter.Simulate(model.latents.col(p), &state, &surface, &error)) << error;
        model.states.push_back(state);
      }
      EXPECT_TRUE(SaveModel(options_.model, model, &error)) << error;
      const testing::SyntheticMuscles held_out = testing::MakeSyntheticMuscles(1, kFrames, 0.3, 23);
      for (int t = 0; t < kFrames; ++t) {
        SurfaceMesh surface = model.neutral;
        surface.vertices = held_out.test_surfaces[t];
        EXPECT_TRUE(WriteObj(dir_->File("t" + std::to_string(t) + ".obj"), surface, &error));
      }
    }
    World().Barrier();
  }

  // RunFitSequenceJob into `out`, in one process on rank 0 (`shared` false; the other
  // ranks wait) or shared among all ranks.
  FitSequenceResult Run(const std::string& out, bool shared, int max_frames = -1) {
    FitSequenceOptions options = options_;
    options.output_dir = dir_->File(out);
    options.max_frames = max_frames;
    options.communicator = shared ? &World() : nullptr;
    FitSequenceResult result;
    std::ostringstream log;
    if (shared || World().is_root()) {
      result = RunFitSequenceJob(options, log);
      EXPECT_EQ(result.status, JobStatus::kOk) << result.message << "\n" << log.str();
    }
    World().Barrier();
    return result;
  }

  std::unique_ptr<testing::SharedTempDir> dir_;
  FitSequenceOptions options_;
};

TEST_F(MpiSequenceTest, SharedFramesGiveTheOutputsOfOneProcess) {
  Run("one", false);
  const FitSequenceResult result = Run("many", true);
  EXPECT_EQ(result.frames_fitted, kFrames);  // on every rank
  EXPECT_EQ(result.frames_resumed, 0);
  if (!World().is_root()) return;
  ExpectSameOutputs(dir_->File("many"), dir_->File("one"));
  std::printf("%d frames over %d ranks: frames.csv (but seconds), latents.bin and %d OBJs "
              "identical to one process\n",
              kFrames, World().size(), kFrames);
}

TEST_F(MpiSequenceTest, APartialRunResumesWithTheOtherNumberOfRanks) {
  Run("one", false);
  // 3 frames in one process, the rest shared.
  Run("from_one", false, 3);
  FitSequenceResult result = Run("from_one", true);
  EXPECT_EQ(result.frames_resumed, 3);
  EXPECT_EQ(result.frames_fitted, kFrames - 3);
  // 3 frames shared (the second round with rank 1 idle), the rest in one process.
  Run("from_many", true, 3);
  result = Run("from_many", false);
  if (!World().is_root()) return;
  EXPECT_EQ(result.frames_resumed, 3);
  EXPECT_EQ(result.frames_fitted, kFrames - 3);
  ExpectSameOutputs(dir_->File("from_one"), dir_->File("one"));
  ExpectSameOutputs(dir_->File("from_many"), dir_->File("one"));
}

TEST_F(MpiSequenceTest, AFrameFailingOnRank1IsReportedByEveryRankWithItsMessage) {
  // Scans (point clouds: every other surface vertex of three targets); the second lies
  // beyond --max_distance of every start (but near enough the model to be read), so that
  // its fit fails on rank 1 while rank 0's succeed; the third, in the next round, is
  // fitted all the same.
  const char* names[3] = {"near.obj", "far.obj", "next.obj"};
  if (World().is_root()) {
    std::string error;
    for (int t = 0; t < 3; ++t) {
      SurfaceMesh pose;
      EXPECT_TRUE(ReadObj(dir_->File("t" + std::to_string(t) + ".obj"), &pose, &error)) << error;
      SurfaceMesh scan;
      scan.vertices.resize(3, (pose.num_vertices() + 1) / 2);
      for (int v = 0; v < pose.num_vertices(); v += 2) scan.vertices.col(v / 2) = pose.vertices.col(v);
      if (t == 1) scan.vertices.array() += 1.0;
      EXPECT_TRUE(WriteObj(dir_->File(names[t]), scan, &error)) << error;
    }
  }
  World().Barrier();
  FitSequenceOptions options = options_;
  options.sequence = dir_->File(names[0]) + "," + dir_->File(names[1]) + "," + dir_->File(names[2]);
  options.points.rematch_every_evaluation = false;
  options.points.max_rounds = 2;
  options.points.max_distance = 0.2;
  std::ostringstream log;
  FitSequenceResult one;
  if (World().is_root()) {
    options.output_dir = dir_->File("one");
    one = RunFitSequenceJob(options, log);
    EXPECT_EQ(one.status, JobStatus::kNotConverged) << one.message;
  }
  World().Barrier();
  options.output_dir = dir_->File("many");
  options.communicator = &World();
  const FitSequenceResult many = RunFitSequenceJob(options, log);
  EXPECT_EQ(many.status, JobStatus::kNotConverged) << many.message;
  EXPECT_NE(many.message.find("1 of 3 frames could not be fitted (the first in this run: "),
            std::string::npos)
      << many.message;
  EXPECT_NE(many.message.find("far.obj: no start: fewer than 3 of the scan's"),
            std::string::npos)
      << many.message;
  EXPECT_EQ(many.frames_fitted, 3);
  EXPECT_EQ(many.frames_failed, 1);
  if (!World().is_root()) return;
  EXPECT_EQ(many.message, one.message);
  EXPECT_NE(log.str().find("frame 2/3 far: could not be fitted ("), std::string::npos)
      << log.str();
  const std::string csv = testing::FramesCsvWithoutSeconds(dir_->File("many/frames.csv"));
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 4) << "the header and 3 frames";
  EXPECT_EQ(csv, testing::FramesCsvWithoutSeconds(dir_->File("one/frames.csv")));
  EXPECT_NE(csv.find(",-1,none,"), std::string::npos) << csv;
  EXPECT_EQ(ReadAll(dir_->File("many/near.obj")), ReadAll(dir_->File("one/near.obj")));
  EXPECT_EQ(ReadAll(dir_->File("many/next.obj")), ReadAll(dir_->File("one/next.obj")));
  EXPECT_FALSE(fs::exists(dir_->File("many/far.obj")));
}

TEST_F(MpiSequenceTest, BadInputStopsEveryRank) {
  // A warm-started sequence cannot be shared.
  FitSequenceOptions options = options_;
  options.communicator = &World();
  options.output_dir = dir_->File("warm");
  options.warm_start = true;
  std::ostringstream log;
  FitSequenceResult result = RunFitSequenceJob(options, log);
  EXPECT_EQ(result.status, JobStatus::kBadInput);
  EXPECT_NE(result.message.find("cannot be shared among 2 ranks: give "
                                "--sequence_warm_start=false"),
            std::string::npos)
      << result.message;
  // An output folder rank 0 cannot create (a file there): every rank stops with its
  // message.
  if (World().is_root()) std::ofstream(dir_->File("a_file")) << "x\n";
  World().Barrier();
  options.warm_start = false;
  options.output_dir = dir_->File("a_file");
  result = RunFitSequenceJob(options, log);
  EXPECT_EQ(result.status, JobStatus::kBadInput);
  EXPECT_NE(result.message.find("a_file: cannot create the folder"), std::string::npos)
      << result.message;
  // Frames.csv of another run (rank 0 reads it).
  if (World().is_root()) {
    fs::create_directories(dir_->File("other"));
    std::ofstream(dir_->File("other/frames.csv")) << "frame,name\n";
  }
  World().Barrier();
  options.output_dir = dir_->File("other");
  result = RunFitSequenceJob(options, log);
  EXPECT_EQ(result.status, JobStatus::kBadInput);
  EXPECT_NE(result.message.find("frames.csv:1: written for another model"), std::string::npos)
      << result.message;
  // A frame whose target another machine holds in another version (here rank 1's
  // frame 1 is another file of the same name).
  if (World().is_root()) {
    fs::create_directories(dir_->File("r1"));
    fs::copy_file(dir_->File("t2.obj"), dir_->File("r1/t1.obj"));
  }
  World().Barrier();
  options.output_dir = dir_->File("unlike");
  std::string all_frames = options.sequence;  // rank 0's (every rank's until here)
  while (!all_frames.empty() && all_frames.back() == ',') all_frames.pop_back();
  if (World().rank() > 0) {
    const std::string own = dir_->File("t1.obj");
    options.sequence.replace(options.sequence.find(own), own.size(), dir_->File("r1/t1.obj"));
  }
  result = RunFitSequenceJob(options, log);
  if (World().size() > 1) {
    EXPECT_EQ(result.status, JobStatus::kBadInput);
    EXPECT_NE(result.message.find("frame 1 (t1) differs from rank 0's"), std::string::npos)
        << result.message;
  }
  // More frames on another machine than on rank 0's (its list has one more).
  const size_t count = std::count(all_frames.begin(), all_frames.end(), ',') + 1;
  const std::string last = fs::path(all_frames.substr(all_frames.rfind(',') + 1)).stem();
  options.sequence =
      World().rank() > 0 ? all_frames : all_frames.substr(0, all_frames.rfind(','));
  options.output_dir = dir_->File("more");
  result = RunFitSequenceJob(options, log);
  if (World().size() > 1) {
    EXPECT_EQ(result.status, JobStatus::kBadInput);
    EXPECT_NE(result.message.find(std::to_string(count) + " frames here, more than rank 0's " +
                                  std::to_string(count - 1) + " (from " + last + " on)"),
              std::string::npos)
        << result.message;
  }
}

}  // namespace
}  // namespace aqs
