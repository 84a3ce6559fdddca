// The error budget (eval/error_budget.h) on the synthetic-muscle bar: the floor is
// prepare's embedded simulation, the pre-training record is what end-to-end training
// starts from, and the record's file round trip.

#include "eval/error_budget.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "jobs/evaluate_job.h"
#include "jobs/learning_jobs.h"
#include "model/model_io.h"
#include "prepare/volumetric_targets.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"
#include "train/trainer.h"

namespace aqs {
namespace {

// The bar with its targets; half of its fixed vertices on a "bone" that turns a little
// in each pose, so that the bone motion of each pose must be applied consistently.
ActiveModel BarWithTargets() {
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(4, 0, 0.3, 5);
  ActiveModel model = data.model;
  Bone bone;
  bone.name = "jaw";
  std::vector<int> kept;
  for (size_t i = 0; i < model.static_vertices.size(); ++i) {
    (i % 2 ? bone.vertices : kept).push_back(model.static_vertices[i]);
  }
  model.static_vertices = kept;
  for (int p = 0; p < model.num_poses(); ++p) {
    RigidTransform t;
    t.rotation = Eigen::AngleAxisd(0.02 * p, Eigen::Vector3d::UnitY()).toRotationMatrix();
    t.translation = Eigen::Vector3d(0, 0.005 * p, 0);
    bone.pose_transforms.push_back(t);
  }
  model.bones.push_back(bone);
  std::ostringstream log;
  std::string error;
  VolumetricTargetOptions targets;
  targets.solver.relative_force_tolerance = 1e-10;
  EXPECT_TRUE(MakeVolumetricTargets(targets, &model, log, &error)) << error;
  return model;
}

std::vector<std::vector<RigidTransform>> AllPoseBones(const ActiveModel& model) {
  std::vector<std::vector<RigidTransform>> bones;
  for (int p = 0; p < model.num_poses(); ++p) bones.push_back(TrainingPoseBones(model, p));
  return bones;
}

TEST(ErrorBudgetTest, FloorIsTheEmbeddedSimulationOfPrepare) {
  const ActiveModel model = BarWithTargets();
  std::vector<ActuationMatrix> targets;
  for (const TrainingPose& pose : model.poses) targets.push_back(pose.target);
  PoseSimulationOptions options;
  options.solver.relative_force_tolerance = 1e-10;
  const std::vector<SimulatedPose> floors =
      SimulateActuations(model, targets, AllPoseBones(model), {}, options);
  ASSERT_EQ(floors.size(), 4u);
  for (int p = 0; p < model.num_poses(); ++p) {
    ASSERT_TRUE(floors[p].converged) << floors[p].message;
    const DistanceSummary s =
        SummarizeDistances(VertexDistances(floors[p].surface, model.poses[p].surface), {});
    // The target is the polar factor of the spring equilibrium's F: simulated, it has zero
    // energy there, so the same surface comes back.
    EXPECT_NEAR(s.mean, model.poses[p].embedding_mean_error, 1e-7) << model.poses[p].name;
    EXPECT_NEAR(s.max, model.poses[p].embedding_max_error, 1e-7) << model.poses[p].name;
    EXPECT_GT(s.max, 0.0);
  }
  // Neither the thread count nor the order of the poses changes the result, bit for bit
  // (every pose starts from the rest factor, not from the previous pose's), also where
  // the solves stop early enough for their path to show.
  options.solver.relative_force_tolerance = 1e-4;
  const std::vector<SimulatedPose> parallel =
      SimulateActuations(model, targets, AllPoseBones(model), {}, options);
  options.num_threads = 1;
  const std::vector<SimulatedPose> serial =
      SimulateActuations(model, targets, AllPoseBones(model), {}, options);
  std::vector<ActuationMatrix> reversed_targets(targets.rbegin(), targets.rend());
  std::vector<std::vector<RigidTransform>> reversed_bones = AllPoseBones(model);
  std::reverse(reversed_bones.begin(), reversed_bones.end());
  const std::vector<SimulatedPose> reversed =
      SimulateActuations(model, reversed_targets, reversed_bones, {}, options);
  for (int p = 0; p < model.num_poses(); ++p) {
    EXPECT_TRUE(serial[p].state == parallel[p].state) << "pose " << p << ": threads";
    EXPECT_TRUE(reversed[model.num_poses() - 1 - p].state == parallel[p].state)
        << "pose " << p << ": order";
  }
}

TEST(ErrorBudgetTest, SummariesOverVertexSubsets) {
  Eigen::VectorXd d(4);
  d << 1.0, 3.0, 0.0, 4.0;
  const DistanceSummary all = SummarizeDistances(d, {});
  EXPECT_DOUBLE_EQ(all.mean, 2.0);
  EXPECT_DOUBLE_EQ(all.rms, std::sqrt(26.0 / 4));
  EXPECT_DOUBLE_EQ(all.max, 4.0);
  const DistanceSummary some = SummarizeDistances(d, {0, 2});
  EXPECT_DOUBLE_EQ(some.mean, 0.5);
  EXPECT_DOUBLE_EQ(some.max, 1.0);
}

// RunPretrainJob's record is the surface error end-to-end training starts from (its
// iteration 0), and its equilibria are training's warm starts.
TEST(ErrorBudgetTest, PretrainRecordIsWhereTrainingStarts) {
  testing::TempDir dir;
  const std::string path = dir.File("model");
  std::string error;
  ASSERT_TRUE(SaveModel(path, BarWithTargets(), &error)) << error;
  PretrainOptions pretrain;
  pretrain.spec.latent_dim = 2;
  pretrain.spec.hidden_dims = {8};
  pretrain.field.node_spacing = 0.4;
  pretrain.max_iterations = 30;
  pretrain.log_every = 0;
  PoseSimulationOptions simulation;
  std::ostringstream log;
  ASSERT_TRUE(RunPretrainJob(path, pretrain, &simulation, log, &error)) << error;
  EXPECT_NE(log.str().find("(b) after pretrain"), std::string::npos) << log.str();

  ActiveModel model;
  ASSERT_TRUE(LoadModel(path, &model, &error)) << error;
  PretrainSurfaceErrors record;
  ASSERT_TRUE(ReadPretrainSurfaceErrors(path, model, &record, &error)) << error;
  ASSERT_EQ(record.distances.rows(), model.num_surface_vertices());
  ASSERT_EQ(record.distances.cols(), model.num_poses());
  ASSERT_EQ(model.states.size(), 4u);
  for (int p = 0; p < model.num_poses(); ++p) {
    EXPECT_EQ(record.converged[p], 1);
    EXPECT_EQ(model.states[p].cols(), model.mesh.num_vertices()) << "no warm start for pose " << p;
  }
  // Pre-training fits targets, not surfaces: it misses the poses by more than the floor.
  EXPECT_GT(record.distances.mean(), 0.0);

  TrainOptions train;
  train.max_iterations = 0;  // evaluate the starting point only
  train.log_every = 0;
  TrainReport report;
  ASSERT_TRUE(TrainEndToEnd(train, &model, &report, log, &error)) << error;
  EXPECT_NEAR(report.initial_mean_surface_error, record.distances.mean(),
              1e-6 * record.distances.mean());
  EXPECT_NEAR(report.max_surface_error, record.distances.maxCoeff(),
              1e-6 * record.distances.maxCoeff());

  // The training log's table: every pose with the three stages.
  std::vector<Eigen::Matrix3Xd> surfaces;
  for (const Eigen::Matrix3Xd& state : model.states) {
    surfaces.push_back(EmbeddedPositions(model.embedding, model.mesh.tets, state));
  }
  const std::string table = TrainingBudgetTable(model, &record, surfaces);
  for (const TrainingPose& pose : model.poses) {
    EXPECT_NE(table.find(pose.name), std::string::npos) << table;
  }
  EXPECT_NE(table.find("mean over poses"), std::string::npos) << table;
  EXPECT_NE(table.find("(c) trained"), std::string::npos) << table;
  EXPECT_EQ(table.find("n/a"), std::string::npos) << table;
  // A pose whose stage (b) did not converge: marked, and no mean over the poses.
  record.converged[1] = 0;
  const std::string unconverged = TrainingBudgetTable(model, &record, surfaces);
  EXPECT_NE(unconverged.find("(not converged)"), std::string::npos) << unconverged;
  const std::string mean_row = unconverged.substr(unconverged.find("mean over poses"));
  EXPECT_NE(mean_row.find("n/a"), std::string::npos) << unconverged;
}

TEST(ErrorBudgetTest, RecordFilesRoundTripAndBadFilesAreNamed) {
  testing::TempDir dir;
  const ActiveModel model = testing::MakeSyntheticMuscles(3, 0, 0.3, 5).model;
  PretrainSurfaceErrors errors;
  std::string error;
  // No record yet: false with no error.
  EXPECT_FALSE(ReadPretrainSurfaceErrors(dir.path(), model, &errors, &error));
  EXPECT_EQ(error, "");
  PretrainSurfaceErrors written;
  written.distances = Eigen::MatrixXd::Random(model.num_surface_vertices(), 3).cwiseAbs();
  written.converged = {1, 0, 1};
  ASSERT_TRUE(WritePretrainSurfaceErrors(dir.path(), model, written, &error)) << error;
  ASSERT_TRUE(ReadPretrainSurfaceErrors(dir.path(), model, &errors, &error)) << error;
  EXPECT_EQ(errors.distances, written.distances);
  EXPECT_EQ(errors.converged, written.converged);

  // Another model's record: the pose names differ.
  ActiveModel other = model;
  other.poses[1].name = "smile";
  EXPECT_FALSE(ReadPretrainSurfaceErrors(dir.path(), other, &errors, &error));
  EXPECT_NE(error.find("surface_errors.txt:5"), std::string::npos) << error;
  EXPECT_NE(error.find("train_1"), std::string::npos) << error;
  // Fewer poses in the model than in the record: the binary file's size is wrong.
  other = model;
  other.poses.pop_back();
  EXPECT_FALSE(ReadPretrainSurfaceErrors(dir.path(), other, &errors, &error));
  EXPECT_NE(error.find("surface_errors.bin"), std::string::npos) << error;
  // A mean that is not a number.
  std::string text;
  {
    std::ifstream in(dir.File("pretrain/surface_errors.txt"));
    text.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const size_t line = text.find("\n1 train_1 ");
  ASSERT_NE(line, std::string::npos) << text;
  std::string damaged = text;
  damaged.replace(line + 11, damaged.find(' ', line + 11) - (line + 11), "x0.5");
  std::ofstream(dir.File("pretrain/surface_errors.txt")) << damaged;
  EXPECT_FALSE(ReadPretrainSurfaceErrors(dir.path(), model, &errors, &error));
  EXPECT_NE(error.find("surface_errors.txt:5"), std::string::npos) << error;
  EXPECT_NE(error.find("mean and max numbers"), std::string::npos) << error;
  std::ofstream(dir.File("pretrain/surface_errors.txt")) << text;
  // A malformed line.
  std::ofstream(dir.File("pretrain/surface_errors.txt"), std::ios::app) << "3 train_3 0.1\n";
  EXPECT_FALSE(ReadPretrainSurfaceErrors(dir.path(), model, &errors, &error));
  EXPECT_NE(error.find("surface_errors.txt:7"), std::string::npos) << error;
  std::ofstream(dir.File("pretrain/surface_errors.txt")) << text;
  // Distances that are no distances (NaN reached the training log and the tables).
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), -1e296}) {
    PretrainSurfaceErrors damaged_distances = written;
    damaged_distances.distances(4, 2) = bad;
    ASSERT_TRUE(WritePretrainSurfaceErrors(dir.path(), model, damaged_distances, &error)) << error;
    EXPECT_FALSE(ReadPretrainSurfaceErrors(dir.path(), model, &errors, &error));
    EXPECT_NE(error.find("surface_errors.bin: the distance of surface vertex 4 in pose 2 is "),
              std::string::npos)
        << error;
  }
}

}  // namespace
}  // namespace aqs
