// The per-pose work of prepare and pre-training in one process (jobs/shared_pose_work.h
// with a LocalCommunicator): exactly what the one-process functions give, and
// MakeVolumetricTargetsOf leaves the poses it is not given alone. The work shared among
// MPI ranks is tested in tests/dist/mpi_pose_work_test.cc.

#include "jobs/shared_pose_work.h"

#include <sstream>

#include <gtest/gtest.h>

#include "dist/model_broadcast.h"
#include "model/model_fingerprint.h"
#include "testing/synthetic_muscles.h"
#include "testing/training_fixtures.h"

namespace aqs {
namespace {

TEST(SharedPoseWorkTest, TargetsOfOneRankAreMakeVolumetricTargets) {
  const ActiveModel base = testing::MakeSyntheticMuscles(3, 0, 0.3, 5).model;
  VolumetricTargetOptions options;
  options.num_threads = 1;
  ActiveModel alone = base, local = base;
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(MakeVolumetricTargets(options, &alone, log, &error)) << error;
  std::vector<std::string> unconverged;
  ASSERT_TRUE(MakeVolumetricTargetsOnRanks(LocalCommunicator(), options, &local, log, &error,
                                           &unconverged))
      << error;
  EXPECT_TRUE(unconverged.empty());
  EXPECT_EQ(log.str().find("shared among"), std::string::npos) << log.str();
  for (int p = 0; p < 3; ++p) {
    EXPECT_EQ(local.poses[p].target, alone.poses[p].target) << p;  // the same solves in order
    EXPECT_EQ(local.poses[p].embedding_max_error, alone.poses[p].embedding_max_error) << p;
  }
}

TEST(SharedPoseWorkTest, TargetsOfSomePosesLeaveTheOthersAlone) {
  ActiveModel model = testing::MakeSyntheticMuscles(3, 0, 0.3, 5).model;
  VolumetricTargetOptions options;
  options.num_threads = 2;
  std::vector<std::string> failures(3, "stale");
  std::ostringstream log;
  MakeVolumetricTargetsOf(options, {0, 2}, nullptr, &model, log, &failures);
  EXPECT_EQ(model.poses[0].target.cols(), model.mesh.num_tets());
  EXPECT_EQ(model.poses[2].target.cols(), model.mesh.num_tets());
  EXPECT_EQ(model.poses[1].target.cols(), 0);
  EXPECT_EQ(failures, (std::vector<std::string>{"", "stale", ""}));
  EXPECT_EQ(log.str().find(model.poses[1].name), std::string::npos) << log.str();
}

TEST(SharedPoseWorkTest, SimulationOfOneRankIsSimulateActuations) {
  testing::SyntheticBarSpec spec;
  spec.num_poses = 3;
  spec.num_threads = 1;
  const ActiveModel model = testing::PretrainedSyntheticBar(spec);
  PoseSimulationOptions options;
  options.num_threads = 2;
  std::vector<std::vector<RigidTransform>> bones;
  for (int p = 0; p < 3; ++p) bones.push_back(TrainingPoseBones(model, p));
  const std::vector<SimulatedPose> alone =
      SimulateActuations(model, DecodeTrainingLatents(model), bones, {}, options);
  const std::vector<SimulatedPose> local =
      SimulateTrainingPosesOnRanks(LocalCommunicator(), model, options);
  ASSERT_EQ(local.size(), 3u);
  for (int p = 0; p < 3; ++p) {
    EXPECT_EQ(local[p].converged, alone[p].converged);
    EXPECT_EQ(local[p].state, alone[p].state) << p;
    EXPECT_EQ(local[p].surface, alone[p].surface) << p;
  }
}

TEST(SharedPoseWorkTest, BroadcastToOneRankChangesNothing) {
  ActiveModel model = testing::MakeSyntheticMuscles(2, 0, 0.3, 5).model;
  const uint64_t before = ModelFingerprint(model);
  std::string error;
  EXPECT_TRUE(BroadcastModel(LocalCommunicator(), &model, &error)) << error;
  EXPECT_EQ(ModelFingerprint(model), before);
}

}  // namespace
}  // namespace aqs
