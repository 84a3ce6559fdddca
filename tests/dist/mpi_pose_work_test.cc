// Prepare's and pre-training's per-pose work shared among the ranks (run by mpirun with 2
// ranks): rank 0's model reaches every rank through its files (dist/model_broadcast.h);
// the volumetric targets and the pre-trained poses' simulations made by the ranks are
// those of one process, and rank 0's store keeps every pose (jobs/shared_pose_work.h).

#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <sstream>

#include <gtest/gtest.h>

#include "dist/communicator.h"
#include "dist/model_broadcast.h"
#include "dist/mpi_world.h"
#include "eval/error_budget.h"
#include "jobs/shared_pose_work.h"
#include "model/model_fingerprint.h"
#include "prepare/volumetric_targets.h"
#include "testing/synthetic_muscles.h"
#include "util/fault_injection.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;
using testing::World;

TEST(MpiPoseWorkTest, BroadcastModelGivesEveryRankRankZerosModel) {
  const Communicator& world = World();
  const ActiveModel expected = testing::PretrainedBar(3);  // the same on every rank
  ActiveModel model;
  if (world.is_root()) model = expected;
  std::string error;
  EXPECT_TRUE(BroadcastModel(world, &model, &error)) << error;
  EXPECT_EQ(ModelFingerprint(model), ModelFingerprint(expected));
  EXPECT_EQ(DecoderArchitectureFingerprint(model), DecoderArchitectureFingerprint(expected));
  EXPECT_EQ(model.decoder_params, expected.decoder_params);
  EXPECT_EQ(model.latents, expected.latents);
  EXPECT_EQ(model.neutral.triangles, expected.neutral.triangles);
  EXPECT_EQ(model.mu, expected.mu);
  ASSERT_EQ(model.num_poses(), 3);
  for (int p = 0; p < 3; ++p) EXPECT_EQ(model.poses[p].target, expected.poses[p].target) << p;
  // Nothing is left in the temporary folders.
  const std::string own = (fs::temp_directory_path() /
                           ("aqs-model-" + std::to_string(getpid()) + "-" +
                            std::to_string(world.rank())))
                              .string();
  EXPECT_FALSE(fs::exists(own)) << own;
}

TEST(MpiPoseWorkTest, ARankWithoutATemporaryFolderStopsEveryRankNamingIt) {
  const Communicator& world = World();
  const int last = world.size() - 1;
  const char* old = std::getenv("TMPDIR");
  const std::string saved = old != nullptr ? old : "";
  if (world.rank() == last && last > 0) setenv("TMPDIR", "/nonexistent-aqs-tmp", 1);
  ActiveModel model;
  if (world.is_root()) model = testing::PretrainedBar(2);
  std::string error;
  const bool ok = BroadcastModel(world, &model, &error);
  if (old != nullptr) {
    setenv("TMPDIR", saved.c_str(), 1);
  } else {
    unsetenv("TMPDIR");
  }
  ASSERT_GT(last, 0);
  EXPECT_FALSE(ok);
  EXPECT_EQ(error.rfind("rank " + std::to_string(last) + ": no temporary directory", 0), 0u)
      << error;
}

TEST(MpiPoseWorkTest, TargetsMadeByTheRanksAreOneProcesssAndRankZeroKeepsThem) {
  const Communicator& world = World();
  testing::SharedTempDir dir;
  const ActiveModel base = testing::MakeSyntheticMuscles(3, 0, 0.3, 5).model;
  VolumetricTargetOptions options;
  options.num_threads = 1;
  ActiveModel alone = base;
  std::ostringstream ignored;
  std::string error;
  EXPECT_TRUE(MakeVolumetricTargets(options, &alone, ignored, &error)) << error;
  if (world.is_root()) options.store_directory = dir.File("store");
  ActiveModel shared = base;
  std::ostringstream log;
  std::vector<std::string> unconverged;
  EXPECT_TRUE(MakeVolumetricTargetsOnRanks(world, options, &shared, log, &error, &unconverged))
      << error;
  if (world.is_root()) {
    EXPECT_TRUE(unconverged.empty());
    EXPECT_NE(log.str().find("3 poses shared among " + std::to_string(world.size()) + " ranks"),
              std::string::npos)
        << log.str();
    // Every pose's line, whichever rank made it.
    for (const TrainingPose& pose : base.poses) {
      EXPECT_NE(log.str().find("  " + pose.name), std::string::npos) << pose.name;
    }
    // One process's targets, bit for bit: every pose's solve starts from the rest
    // factor, whichever poses a rank's worker solved before.
    for (int p = 0; p < 3; ++p) {
      ASSERT_EQ(shared.poses[p].target.cols(), base.mesh.num_tets()) << p;
      EXPECT_TRUE(shared.poses[p].target == alone.poses[p].target)
          << p << ": " << (shared.poses[p].target - alone.poses[p].target).cwiseAbs().maxCoeff();
      EXPECT_EQ(shared.poses[p].embedding_mean_error, alone.poses[p].embedding_mean_error);
      EXPECT_TRUE(fs::exists(dir.File("store/000" + std::to_string(p) + ".txt"))) << p;
    }
  }
  // Run again: every pose from rank 0's store, bit for bit, whatever the ranks hold.
  ActiveModel again = base;
  std::ostringstream rerun_log;
  EXPECT_TRUE(MakeVolumetricTargetsOnRanks(world, options, &again, rerun_log, &error, nullptr))
      << error;
  if (world.is_root()) {
    EXPECT_NE(rerun_log.str().find("3 of 3 poses' targets were taken from"), std::string::npos)
        << rerun_log.str();
    for (int p = 0; p < 3; ++p) EXPECT_EQ(again.poses[p].target, shared.poses[p].target) << p;
  }
}

// The targets rank 0's store holds (NNNN.txt records) each time rank 0 starts a pose.
std::string g_store_path;
std::vector<int> g_stored_at_pose;

void CountStoredTargets(const char* point) {
  if (std::string(point) != "targets:pose") return;
  int count = 0;
  for (const auto& entry : fs::directory_iterator(g_store_path)) {
    if (entry.path().extension() == ".txt" && entry.path().filename() != "key.txt") ++count;
  }
  g_stored_at_pose.push_back(count);
}

TEST(MpiPoseWorkTest, RankZeroKeepsEveryRanksTargetsBeforeTheNextRound) {
  const Communicator& world = World();
  testing::SharedTempDir dir;
  const ActiveModel base = testing::MakeSyntheticMuscles(4, 0, 0.3, 5).model;
  VolumetricTargetOptions options;
  options.num_threads = 1;  // rounds of one pose per rank
  if (world.is_root()) {
    options.store_directory = dir.File("store");
    g_store_path = options.store_directory;
    g_stored_at_pose.clear();
    SetFaultHookForTesting(&CountStoredTargets);
  }
  ActiveModel shared = base;
  std::ostringstream log;
  std::string error;
  EXPECT_TRUE(MakeVolumetricTargetsOnRanks(world, options, &shared, log, &error, nullptr))
      << error;
  if (!world.is_root()) return;
  SetFaultHookForTesting(nullptr);
  // Rank 0 makes poses 0 and size (of 4, one a round): when it starts its second, the
  // first round's (one per rank) are kept, so that a kill then would lose none of them.
  const int size = world.size();
  const std::vector<int> expected =
      size == 1 ? std::vector<int>{0, 1, 2, 3}
                : size < 4 ? std::vector<int>{0, size} : std::vector<int>{0};
  EXPECT_EQ(g_stored_at_pose, expected) << log.str();
}

TEST(MpiPoseWorkTest, APoseThatDoesNotConvergeOnAnotherRankReachesRankZero) {
  const Communicator& world = World();
  const ActiveModel base = testing::MakeSyntheticMuscles(3, 0, 0.3, 5).model;
  VolumetricTargetOptions options;
  options.num_threads = 1;
  options.continuation_steps = 1;
  options.solver.max_iterations = 1;
  options.solver.max_lbfgs_iterations = 1;
  ActiveModel shared = base;
  std::ostringstream log;
  std::vector<std::string> unconverged;
  std::string error;
  EXPECT_TRUE(MakeVolumetricTargetsOnRanks(world, options, &shared, log, &error, &unconverged))
      << error;
  if (world.is_root()) {
    // Pose 1 is rank 1's (of 2); its message arrives in pose order with the others'.
    ASSERT_EQ(unconverged.size(), 3u) << log.str();
    for (int p = 0; p < 3; ++p) {
      EXPECT_EQ(unconverged[p].rfind("pose '" + base.poses[p].name +
                                     "': the embedded simulation did not converge", 0),
                0u)
          << unconverged[p];
    }
  }
  // Without a list, the first pose's message is every rank's error.
  ActiveModel again = base;
  EXPECT_FALSE(MakeVolumetricTargetsOnRanks(world, options, &again, log, &error, nullptr));
  EXPECT_EQ(error.rfind("pose '" + base.poses[0].name + "'", 0), 0u) << error;
}

TEST(MpiPoseWorkTest, RanksWithOtherTargetOptionsAreRefused) {
  const Communicator& world = World();
  const int last = world.size() - 1;
  ActiveModel model = testing::MakeSyntheticMuscles(2, 0, 0.3, 5).model;
  VolumetricTargetOptions options;
  options.num_threads = 1;
  if (world.rank() == last && last > 0) options.relative_stiffness = 50.0;
  std::ostringstream log;
  std::string error;
  const bool ok = MakeVolumetricTargetsOnRanks(world, options, &model, log, &error, nullptr);
  ASSERT_GT(last, 0);
  EXPECT_FALSE(ok);
  EXPECT_NE(error.find("rank " + std::to_string(last) + ": the volumetric targets' options"),
            std::string::npos)
      << error;
}

TEST(MpiPoseWorkTest, PretrainedPosesSimulatedByTheRanksAreOneProcesss) {
  const Communicator& world = World();
  const ActiveModel model = testing::PretrainedBar(3);
  PoseSimulationOptions options;
  options.num_threads = 1;
  const std::vector<SimulatedPose> shared = SimulateTrainingPosesOnRanks(world, model, options);
  if (!world.is_root()) {
    EXPECT_TRUE(shared.empty());
    return;
  }
  const std::vector<SimulatedPose> alone =
      SimulateTrainingPosesOnRanks(LocalCommunicator(), model, options);
  ASSERT_EQ(shared.size(), 3u);
  ASSERT_EQ(alone.size(), 3u);
  for (int p = 0; p < 3; ++p) {
    EXPECT_EQ(shared[p].converged, alone[p].converged) << p;
    EXPECT_EQ(shared[p].message, alone[p].message) << p;
    // Bit for bit: a pose's simulation starts from rest with a fresh factorization.
    EXPECT_EQ(shared[p].state, alone[p].state) << p;
    EXPECT_EQ(shared[p].surface, alone[p].surface) << p;
  }
}

// Poses that another rank could not bring to equilibrium come back unconverged, as in one
// process (every earlier scene converged).
TEST(MpiPoseWorkTest, UnconvergedPosesOfOtherRanksStayUnconverged) {
  const Communicator& world = World();
  const ActiveModel model = testing::PretrainedBar(3);
  PoseSimulationOptions options;
  options.num_threads = 1;
  options.solver.max_iterations = 1;
  options.solver.max_lbfgs_iterations = 1;
  const std::vector<SimulatedPose> shared = SimulateTrainingPosesOnRanks(world, model, options);
  if (!world.is_root()) return;
  const std::vector<SimulatedPose> alone =
      SimulateTrainingPosesOnRanks(LocalCommunicator(), model, options);
  ASSERT_EQ(shared.size(), 3u);
  for (int p = 0; p < 3; ++p) EXPECT_EQ(shared[p].converged, alone[p].converged) << "pose " << p;
  EXPECT_FALSE(alone[1].converged) << "the scene must leave pose 1 unconverged";
}

}  // namespace
}  // namespace aqs
