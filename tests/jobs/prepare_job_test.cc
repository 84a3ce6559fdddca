#include "jobs/prepare_job.h"

#include <sstream>

#include <gtest/gtest.h>

#include "mesh/mesh_io.h"
#include "model/model_io.h"
#include "testing/temp_dir.h"
#include "testing/test_surfaces.h"

namespace aqs {
namespace {

// A sphere of radius 2 with two holes, and poses of it: a stretch, a bulge, a twist.
class PrepareJobTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SurfaceMesh sphere = testing::Icosphere(3, 2.0);
    sphere.triangles = testing::RemoveTriangles(sphere.triangles, {0, 1, 2, 3, 400, 401});
    neutral_ = sphere;
    std::string error;
    ASSERT_TRUE(WriteObj(dir_.File("neutral.obj"), neutral_, &error)) << error;
    for (int p = 0; p < 3; ++p) {
      SurfaceMesh pose = neutral_;
      for (int v = 0; v < pose.num_vertices(); ++v) {
        Eigen::Vector3d x = pose.vertices.col(v);
        if (p == 0) x.x() *= 1.06;
        if (p == 1 && x.z() > 1.0) x *= 1.0 + 0.1 * (x.z() - 1.0);
        if (p == 2) {
          const double angle = 0.08 * x.z();
          x = Eigen::Vector3d(std::cos(angle) * x.x() - std::sin(angle) * x.y(),
                              std::sin(angle) * x.x() + std::cos(angle) * x.y(), x.z());
        }
        pose.vertices.col(v) = x;
      }
      const std::string path = dir_.File("pose" + std::to_string(p) + ".obj");
      ASSERT_TRUE(WriteObj(path, pose, &error)) << error;
      options_.pose_paths.push_back(path);
    }
    options_.neutral = dir_.File("neutral.obj");
    options_.meshing.spacing = 0.45;
    options_.boundary.fixed_depth = 1.2;
    options_.output = dir_.File("model");
  }

  testing::TempDir dir_;
  SurfaceMesh neutral_;
  PrepareJobOptions options_;
};

TEST_F(PrepareJobTest, SurfaceWithHolesBecomesAModel) {
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(RunPrepareJob(options_, log, &error)) << error << "\n" << log.str();
  ActiveModel model;
  ASSERT_TRUE(LoadModel(options_.output, &model, &error)) << error;
  EXPECT_EQ(model.num_poses(), 3);
  EXPECT_EQ(model.poses[0].name, "pose0");
  EXPECT_EQ(model.num_surface_vertices(), neutral_.num_vertices());
  EXPECT_GT(model.mesh.num_tets(), 200);
  EXPECT_FALSE(model.static_vertices.empty());
  for (double d : model.embedding.outside_distance) EXPECT_EQ(d, 0.0);
  for (const TrainingPose& pose : model.poses) {
    EXPECT_EQ(pose.target.cols(), model.mesh.num_tets());
    // The passive body follows the pose closely (poses move up to ~0.2).
    EXPECT_LT(pose.embedding_mean_error, 0.01) << pose.name;
    EXPECT_LT(pose.embedding_max_error, 0.05) << pose.name;
  }
  EXPECT_NE(log.str().find("fixed by depth > 1.2"), std::string::npos) << log.str();
}

TEST_F(PrepareJobTest, UserTetMeshAndBoxRule) {
  // The mesh of a previous run, given as a user mesh; fixed by a box instead of depth.
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(RunPrepareJob(options_, log, &error)) << error;
  ActiveModel first;
  ASSERT_TRUE(LoadModel(options_.output, &first, &error)) << error;
  ASSERT_TRUE(WriteMeditMesh(dir_.File("user.mesh"), first.mesh, &error)) << error;
  PrepareJobOptions options = options_;
  options.tet_mesh = dir_.File("user.mesh");
  options.boundary.fixed_depth = -1;
  options.boundary.fixed_boxes = {Eigen::AlignedBox3d(Eigen::Vector3d(-3, -3, -3),
                                                      Eigen::Vector3d(3, 3, -1.5))};
  options.output = dir_.File("model2");
  ASSERT_TRUE(RunPrepareJob(options, log, &error)) << error;
  ActiveModel second;
  ASSERT_TRUE(LoadModel(options.output, &second, &error)) << error;
  EXPECT_EQ(second.mesh.tets, first.mesh.tets);
  for (int v : second.static_vertices) EXPECT_LE(second.mesh.vertices(2, v), -1.5);
}

TEST_F(PrepareJobTest, BadInputsFailClearly) {
  std::ostringstream log;
  std::string error;
  // A pose with another vertex count.
  SurfaceMesh small = testing::Icosphere(2, 2.0);
  ASSERT_TRUE(WriteObj(dir_.File("small.obj"), small, &error));
  PrepareJobOptions options = options_;
  options.pose_paths.push_back(dir_.File("small.obj"));
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("small.obj: 162 vertices, but the neutral surface has 642"),
            std::string::npos) << error;
  // No poses.
  options = options_;
  options.pose_paths.clear();
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("pose set is empty"), std::string::npos) << error;
  // A surface that encloses nothing: a flat patch.
  SurfaceMesh patch;
  patch.vertices.resize(3, 4);
  patch.vertices << 0, 1, 1, 0,  //
      0, 0, 1, 1,                //
      0, 0, 0, 0;
  patch.triangles.resize(3, 2);
  patch.triangles << 0, 0,  //
      1, 2,                 //
      2, 3;
  ASSERT_TRUE(WriteObj(dir_.File("patch.obj"), patch, &error));
  options = options_;
  options.neutral = dir_.File("patch.obj");
  options.pose_paths = {dir_.File("patch.obj")};
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("patch.obj"), std::string::npos) << error;
  EXPECT_NE(error.find("encloses"), std::string::npos) << error;
  // No fixed vertices.
  options = options_;
  options.boundary.fixed_depth = -1;
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("no simulation vertex is fixed"), std::string::npos) << error;
  // A missing neutral.
  options = options_;
  options.neutral = dir_.File("missing.obj");
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("missing.obj: cannot open"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
