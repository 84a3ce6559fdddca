#include "jobs/prepare_job.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>

#include "mesh/element_subset.h"
#include "mesh/mesh_io.h"
#include "model/model_io.h"
#include "prepare/halfway_poses.h"
#include "prepare/target_store.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"
#include "testing/test_surfaces.h"
#include "util/fault_injection.h"

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
  // Elements pruned at weakly held vertices leave a few surface vertices just outside.
  for (double d : model.embedding.outside_distance) EXPECT_LT(d, options_.meshing.spacing);
  for (const TrainingPose& pose : model.poses) {
    EXPECT_EQ(pose.target.cols(), model.mesh.num_tets());
    // The passive body follows the pose closely (poses move up to ~0.2).
    EXPECT_LT(pose.embedding_mean_error, 0.01) << pose.name;
    EXPECT_LT(pose.embedding_max_error, 0.05) << pose.name;
  }
  EXPECT_NE(log.str().find("fixed by depth > 1.2"), std::string::npos) << log.str();
}

std::string g_store, g_snapshot;

// At the point where a prepare has written the model and not yet removed its targets'
// store: a copy of the store, as a kill there would leave it.
void SnapshotTheStore(const char* point) {
  if (std::string(point) == "prepare:model_written") {
    std::filesystem::copy(g_store, g_snapshot, std::filesystem::copy_options::recursive);
  }
}

// A prepare stopped after it wrote the model but before it removed its targets' store
// left the store: a rerun that keeps the model removes it; a store of other options (a
// stopped run's, which may resume) stays.
TEST_F(PrepareJobTest, AKeptModelsLeftoverTargetStoreIsRemoved) {
  g_store = TargetStorePath(options_.output);
  g_snapshot = dir_.File("snapshot");
  std::ostringstream log;
  std::string error;
  const FaultHook previous = SetFaultHookForTesting(&SnapshotTheStore);
  ASSERT_TRUE(RunPrepareJob(options_, log, &error)) << error;
  SetFaultHookForTesting(previous);
  ASSERT_TRUE(std::filesystem::exists(g_snapshot + "/key.txt"));
  ASSERT_FALSE(std::filesystem::exists(g_store));
  std::filesystem::rename(g_snapshot, g_store);
  PrepareJobOptions keep = options_;
  keep.keep_same_model = true;
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("cleanup: removed " + g_store + ", the targets' store of a run "
                           "stopped after it wrote the model"),
            std::string::npos)
      << log.str();
  EXPECT_FALSE(std::filesystem::exists(g_store));
  std::filesystem::create_directories(g_store);
  std::ofstream(g_store + "/key.txt") << "the targets of other options\n";
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_TRUE(std::filesystem::exists(g_store + "/key.txt"));
  EXPECT_EQ(log.str().find("cleanup:"), std::string::npos) << log.str();
}

// keep_same_model (aqs_pipeline's rerun): a model of the same inputs and options is
// kept as it is; another pose surface, mesh option or target option makes a new one;
// a model whose targets did not all converge records no key and is never kept.
TEST_F(PrepareJobTest, TheSameModelIsKeptAndAnotherIsMadeAnew) {
  std::ostringstream log;
  std::string error;
  ASSERT_TRUE(RunPrepareJob(options_, log, &error)) << error;
  ActiveModel first;
  ASSERT_TRUE(LoadModel(options_.output, &first, &error)) << error;
  EXPECT_EQ(first.target_key.size(), 16u);
  PrepareJobOptions keep = options_;
  keep.keep_same_model = true;
  const auto written = std::filesystem::last_write_time(options_.output + "/model.txt");
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("is the model of these inputs and flags (targets " +
                           first.target_key + "): kept, with its learned state (not "
                           "pre-trained)"),
            std::string::npos)
      << log.str();
  EXPECT_EQ(std::filesystem::last_write_time(options_.output + "/model.txt"), written);
  // Another pose surface.
  SurfaceMesh pose;
  ASSERT_TRUE(ReadObj(options_.pose_paths[2], &pose, &error)) << error;
  pose.vertices(0, 7) += 1e-3;
  ASSERT_TRUE(WriteObj(options_.pose_paths[2], pose, &error)) << error;
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("is prepared anew: its mesh, material, fixed vertices, bones, "
                           "embedding or poses differ"),
            std::string::npos)
      << log.str();
  // Another target option.
  keep.targets.relative_stiffness *= 2;
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("is prepared anew: its targets were made with other options"),
            std::string::npos)
      << log.str();
  // The neutral's faces in another order (the same vertices and surface): they weigh the
  // attachment springs, so the model is not kept.
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("kept, with its learned state"), std::string::npos) << log.str();
  SurfaceMesh reordered = neutral_;
  reordered.triangles.col(0).swap(reordered.triangles.col(1));
  ASSERT_TRUE(WriteObj(options_.neutral, reordered, &error)) << error;
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("is prepared anew: its neutral's faces differ from these inputs'"),
            std::string::npos)
      << log.str();
  // Targets that do not converge: the model is written (status kNotConverged) without a
  // key, and a rerun makes it again.
  keep.targets.solver.max_iterations = 1;
  keep.targets.solver.max_lbfgs_iterations = 1;
  keep.targets.continuation_steps = 1;
  JobStatus status = JobStatus::kOk;
  EXPECT_FALSE(RunPrepareJob(keep, log, &error, &status));
  EXPECT_EQ(status, JobStatus::kNotConverged) << error;
  ActiveModel unconverged;
  ASSERT_TRUE(LoadModel(options_.output, &unconverged, &error)) << error;
  EXPECT_TRUE(unconverged.target_key.empty());
  log.str("");
  EXPECT_FALSE(RunPrepareJob(keep, log, &error, &status));
  EXPECT_NE(log.str().find("is prepared anew: it records no key of its targets"),
            std::string::npos)
      << log.str();
  // A model that cannot be read: prepared anew, unless it holds a learned state (a
  // damaged file of a trained model), which it refuses to discard.
  keep = options_;
  keep.keep_same_model = true;
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  std::ofstream(options_.output + "/mu.bin") << "damaged";
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("is prepared anew: it cannot be read"), std::string::npos) << log.str();
  std::filesystem::create_directories(options_.output + "/learned");
  const std::string decoder = options_.output + "/learned/decoder.txt";
  std::ofstream(decoder) << "a decoder with a damaged line\n";
  EXPECT_FALSE(RunPrepareJob(keep, log, &error, &status));
  EXPECT_EQ(status, JobStatus::kBadInput);
  EXPECT_NE(error.find("cannot be read ("), std::string::npos) << error;
  EXPECT_NE(error.find("would discard its learned state (" + decoder), std::string::npos)
      << error;
  EXPECT_TRUE(std::filesystem::exists(decoder));
  keep.keep_same_model = false;  // --restart
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_FALSE(std::filesystem::exists(decoder));
}

// Two bodies, fixed vertices in one only: the other piece of the simulation mesh, which
// its surface is embedded in, could move rigidly, and is refused (prepare wrote such
// models, whose every solve was singular).
TEST_F(PrepareJobTest, APieceOfTheMeshWithoutFixedVerticesIsRefused) {
  SurfaceMesh two = neutral_;
  const int n = neutral_.num_vertices();
  two.vertices.resize(3, 2 * n);
  two.vertices << neutral_.vertices, neutral_.vertices.colwise() + Eigen::Vector3d(10, 0, 0);
  two.triangles.resize(3, 2 * neutral_.num_triangles());
  two.triangles << neutral_.triangles, neutral_.triangles.array() + n;
  std::string error;
  ASSERT_TRUE(WriteObj(dir_.File("two.obj"), two, &error)) << error;
  SurfaceMesh stretched = two;
  stretched.vertices.row(2) *= 1.05;
  ASSERT_TRUE(WriteObj(dir_.File("two_stretched.obj"), stretched, &error)) << error;
  PrepareJobOptions options = options_;
  options.neutral = dir_.File("two.obj");
  options.pose_paths = {dir_.File("two_stretched.obj")};
  options.boundary.fixed_depth = 0.0;
  options.boundary.fixed_boxes.emplace_back(Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1));
  std::ostringstream log;
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("has fewer than 3 fixed vertices off one line: it could move rigidly"),
            std::string::npos)
      << error;
  EXPECT_NE(error.find("surface vertices are embedded in it"), std::string::npos) << error;
  options.boundary.fixed_boxes.emplace_back(Eigen::Vector3d(9, -1, -1), Eigen::Vector3d(11, 1, 1));
  EXPECT_TRUE(RunPrepareJob(options, log, &error)) << error;
}

// Elements at vertices that fewer than min_elements_per_vertex elements hold (here
// the outer corners of elements kept for a surface vertex) are removed; the surface
// vertices they held are embedded just outside the mesh.
TEST_F(PrepareJobTest, WeaklyHeldVerticesArePruned) {
  std::ostringstream log;
  std::string error;
  PrepareJobOptions unpruned = options_;
  unpruned.min_elements_per_vertex = 0;
  unpruned.output = dir_.File("unpruned");
  ASSERT_TRUE(RunPrepareJob(unpruned, log, &error)) << error;
  ActiveModel loose;
  ASSERT_TRUE(LoadModel(unpruned.output, &loose, &error)) << error;
  auto count_below = [](const TetMesh& mesh, int min) {
    int below = 0;
    for (int c : VertexElementCounts(mesh)) below += c < min;
    return below;
  };
  EXPECT_GT(count_below(loose.mesh, 3), 10);

  log.str("");
  ASSERT_TRUE(RunPrepareJob(options_, log, &error)) << error;
  ActiveModel model;
  ASSERT_TRUE(LoadModel(options_.output, &model, &error)) << error;
  EXPECT_EQ(count_below(model.mesh, 4), 0);
  EXPECT_LT(model.mesh.num_tets(), loose.mesh.num_tets());
  EXPECT_NE(log.str().find("held by fewer than 4 elements removed"), std::string::npos)
      << log.str();
  for (double d : model.embedding.outside_distance) EXPECT_LT(d, options_.meshing.spacing);
  for (size_t p = 0; p < model.poses.size(); ++p) {
    // The targets' surface error stays of the unpruned mesh's order: on this coarse
    // sphere (under 5 elements across its radius) the twist's goes from 5.1e-4 to
    // 1.0e-3 (on the demo face, 0.00661 -> 0.00668 on average over its poses).
    EXPECT_LT(model.poses[p].embedding_mean_error,
              2.5 * loose.poses[p].embedding_mean_error + 1e-4)
        << model.poses[p].name;
  }
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
  // The same mesh in another unit (x 10), or moved away: refused before any work.
  for (const double scale : {10.0, 1.0}) {
    TetMesh other = first.mesh;
    other.vertices *= scale;
    if (scale == 1.0) other.vertices.row(0).array() += 50.0;
    ASSERT_TRUE(WriteMeditMesh(dir_.File("other.mesh"), other, &error)) << error;
    options.tet_mesh = dir_.File("other.mesh");
    EXPECT_FALSE(RunPrepareJob(options, log, &error)) << scale;
    EXPECT_NE(error.find("other.mesh: the simulation mesh's box"), std::string::npos) << error;
    EXPECT_NE(error.find("is it in another unit or frame?"), std::string::npos) << error;
  }
}

// A piece of a user's mesh that no fixed vertex holds and no surface vertex is embedded
// in (a lone element inside the sphere; pruning, which would take it too, is off): removed,
// and the model is the one made without it.
TEST_F(PrepareJobTest, AFreePieceWithoutSurfaceIsRemoved) {
  std::ostringstream log;
  std::string error;
  PrepareJobOptions options = options_;
  options.min_elements_per_vertex = 0;
  options.output = dir_.File("plain");
  ASSERT_TRUE(RunPrepareJob(options, log, &error)) << error;
  ActiveModel plain;
  ASSERT_TRUE(LoadModel(options.output, &plain, &error)) << error;
  ASSERT_TRUE(WriteMeditMesh(dir_.File("plain.mesh"), plain.mesh, &error)) << error;
  TetMesh lone = testing::UnitTet();  // edges of 0.1 at the centre
  lone.vertices *= 0.1;
  const int m = plain.mesh.num_tets();
  const TetMesh with_lone = testing::JoinMeshes(plain.mesh, lone);
  ASSERT_TRUE(WriteMeditMesh(dir_.File("lone.mesh"), with_lone, &error)) << error;
  options.boundary.fixed_depth = -1;  // a box below: the lone element at the centre is free
  options.boundary.fixed_boxes = {Eigen::AlignedBox3d(Eigen::Vector3d(-3, -3, -3),
                                                      Eigen::Vector3d(3, 3, -1.5))};
  options.tet_mesh = dir_.File("plain.mesh");
  options.output = dir_.File("from_plain");
  ASSERT_TRUE(RunPrepareJob(options, log, &error)) << error;
  options.tet_mesh = dir_.File("lone.mesh");
  options.output = dir_.File("from_lone");
  log.str("");
  ASSERT_TRUE(RunPrepareJob(options, log, &error)) << error;
  EXPECT_NE(log.str().find("removed 1 free piece(s) of the simulation mesh that no fixed vertex "
                           "holds and no surface vertex is embedded in: 1 element(s) (the "
                           "first was element " + std::to_string(m) + ") and 4 vertices"),
            std::string::npos)
      << log.str();
  ActiveModel expected, model;
  ASSERT_TRUE(LoadModel(dir_.File("from_plain"), &expected, &error)) << error;
  ASSERT_TRUE(LoadModel(dir_.File("from_lone"), &model, &error)) << error;
  EXPECT_EQ(model.mesh.tets, expected.mesh.tets);
  EXPECT_EQ(model.mesh.vertices, expected.mesh.vertices);
  EXPECT_EQ(model.static_vertices, expected.static_vertices);
  EXPECT_EQ(model.embedding.element, expected.embedding.element);
  ASSERT_EQ(model.num_poses(), expected.num_poses());
  EXPECT_EQ(model.poses[0].target, expected.poses[0].target);
}

// --fixed_list indexes the vertices of --tet_mesh's file, which prepare renumbers when it
// prunes weakly held elements: the listed vertices are fixed where they are, and a
// listed vertex that pruning removed is named.
TEST_F(PrepareJobTest, FixedListIndexesTheUserMeshsOwnVertices) {
  std::ostringstream log;
  std::string error;
  PrepareJobOptions unpruned = options_;
  unpruned.min_elements_per_vertex = 0;
  unpruned.output = dir_.File("loose");
  ASSERT_TRUE(RunPrepareJob(unpruned, log, &error)) << error;
  ActiveModel loose;
  ASSERT_TRUE(LoadModel(unpruned.output, &loose, &error)) << error;
  ASSERT_TRUE(WriteMeditMesh(dir_.File("loose.mesh"), loose.mesh, &error)) << error;
  std::vector<int> kept;
  PruneWeaklyHeldElements(loose.mesh, options_.min_elements_per_vertex, nullptr, &kept);
  ASSERT_LT(kept.size(), static_cast<size_t>(loose.mesh.num_vertices())) << "pruning renumbers";
  std::vector<bool> survives(loose.mesh.num_vertices(), false);
  for (int v : kept) survives[v] = true;
  std::string list, removed_list;
  int listed = 0, removed = -1;
  for (int v = 0; v < loose.mesh.num_vertices(); ++v) {
    if (loose.mesh.vertices(2, v) > -1.2) continue;
    if (survives[v]) {
      list += std::to_string(v) + "\n";
      ++listed;
    } else if (removed < 0) {
      removed = v;
    }
  }
  ASSERT_GT(listed, 5);
  ASSERT_GE(removed, 0);
  std::ofstream(dir_.File("bottom.txt")) << list;
  std::ofstream(dir_.File("with_removed.txt")) << list << removed << "\n";
  PrepareJobOptions options = options_;
  options.tet_mesh = dir_.File("loose.mesh");
  options.boundary.fixed_depth = -1;
  options.boundary.fixed_list = dir_.File("bottom.txt");
  options.output = dir_.File("listed");
  log.str("");
  ASSERT_TRUE(RunPrepareJob(options, log, &error)) << error;
  ActiveModel model;
  ASSERT_TRUE(LoadModel(options.output, &model, &error)) << error;
  EXPECT_LT(model.mesh.num_vertices(), loose.mesh.num_vertices());
  ASSERT_EQ(static_cast<int>(model.static_vertices.size()), listed);
  for (int v : model.static_vertices) {
    EXPECT_LE(model.mesh.vertices(2, v), -1.2) << "vertex " << v << " was not listed";
  }
  options.boundary.fixed_list = dir_.File("with_removed.txt");
  options.output = dir_.File("listed_removed");
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("with_removed.txt: vertex " + std::to_string(removed) +
                       " is not in the simulation mesh"),
            std::string::npos)
      << error;
}

// --mirror_poses: the stretch and the bulge are symmetric in x = 0 and get no image; the
// twist's image (the opposite twist) is appended with a target of its own, which the
// embedded simulation follows as closely as the twist's.
TEST_F(PrepareJobTest, MirrorImagesOfAsymmetricPoses) {
  std::ostringstream log;
  std::string error;
  PrepareJobOptions options = options_;
  options.mirror.axis = 0;
  ASSERT_TRUE(RunPrepareJob(options, log, &error)) << error << "\n" << log.str();
  ActiveModel model;
  ASSERT_TRUE(LoadModel(options.output, &model, &error)) << error;
  ASSERT_EQ(model.num_poses(), 4) << log.str();
  EXPECT_EQ(model.poses[3].name, "mirror_pose2");
  EXPECT_EQ(model.poses[3].target.cols(), model.mesh.num_tets());
  EXPECT_LT(model.poses[3].embedding_mean_error, 2.0 * model.poses[2].embedding_mean_error + 1e-4);
  // The image's surface: the twist by -0.08 z.
  for (int v = 0; v < model.num_surface_vertices(); ++v) {
    const Eigen::Vector3d x = neutral_.vertices.col(v);
    const double angle = -0.08 * x.z();
    const Eigen::Vector3d expected(std::cos(angle) * x.x() - std::sin(angle) * x.y(),
                                   std::sin(angle) * x.x() + std::cos(angle) * x.y(), x.z());
    EXPECT_LT((model.poses[3].surface.col(v) - expected).norm(), 1e-4) << v;
  }
  EXPECT_NE(log.str().find("pose0: symmetric"), std::string::npos) << log.str();
  // A neutral that is not symmetric in the plane y = 0.5 is refused.
  options.mirror.axis = 1;
  options.mirror.plane = 0.5;
  options.output = dir_.File("refused");
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("not mirror-symmetric (--mirror_poses)"), std::string::npos) << error;
}

// --halfway_poses with --mirror_poses and a bone (a copy of the sphere, driving the
// fixed core's lower half) that the twist's pose turns by 0.1 about the z axis: the
// twist and its mirror image get halfway poses (half_pose2, half_mirror_pose2), the
// symmetric poses' bones stay and get none. Every bone transform is saved and read back
// (6 per bone), the halfway bones are halfway along their screw motions, and the halfway
// surfaces are the blends at 1/2. A rerun that keeps the same model keeps it; a run
// stopped after the model was written resumes from its targets' store; another
// threshold makes the model anew.
TEST_F(PrepareJobTest, HalfwayPosesWithMirrorImagesAndABone) {
  std::string error;
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  SurfaceMesh turned = neutral_;
  turned.vertices = turn * neutral_.vertices;
  ASSERT_TRUE(WriteObj(dir_.File("bone_pose2.obj"), turned, &error)) << error;
  PrepareJobOptions options = options_;
  BoneRule bone;
  bone.name = "core";
  bone.neutral_mesh = options_.neutral;
  bone.pose_mesh_pattern = dir_.File("bone_{pose}.obj");
  bone.region_boxes.emplace_back(Eigen::Vector3d(-2, -2, -2), Eigen::Vector3d(2, 2, 0));
  options.boundary.bones.push_back(bone);
  options.mirror.axis = 0;
  options.halfway.enabled = true;
  g_store = TargetStorePath(options.output);
  g_snapshot = dir_.File("halfway_snapshot");
  std::ostringstream log;
  const FaultHook previous = SetFaultHookForTesting(&SnapshotTheStore);
  ASSERT_TRUE(RunPrepareJob(options, log, &error)) << error << "\n" << log.str();
  SetFaultHookForTesting(previous);
  ActiveModel model;
  ASSERT_TRUE(LoadModel(options.output, &model, &error)) << error;
  ASSERT_EQ(model.num_poses(), 6) << log.str();
  const std::vector<std::string> names = {"pose0",        "pose1",      "pose2",
                                          "mirror_pose2", "half_pose2", "half_mirror_pose2"};
  for (int p = 0; p < 6; ++p) {
    EXPECT_EQ(model.poses[p].name, names[p]);
    EXPECT_EQ(model.poses[p].target.cols(), model.mesh.num_tets()) << names[p];
  }
  ASSERT_EQ(model.bones.size(), 1u);
  const Bone& core = model.bones[0];
  ASSERT_EQ(core.pose_transforms.size(), 6u);
  ASSERT_FALSE(core.vertices.empty());
  for (int p : {0, 1}) EXPECT_LT(LargestBoneMotion(model, 0, p), 1e-9) << names[p];
  for (int p : {2, 3}) EXPECT_GT(LargestBoneMotion(model, 0, p), 1e-2) << names[p];
  // The mirror image turns the other way (x -> -x maps a turn about z to its inverse),
  // and so do the halfway poses: T_3(v) = M T_2(M v), T_5(v) = M T_4(M v), T_5 != T_4.
  const Eigen::Vector3d flip(-1, 1, 1);
  for (int v : core.vertices) {
    const Eigen::Vector3d x = model.mesh.vertices.col(v);
    for (int p : {2, 4}) {
      EXPECT_LT((core.pose_transforms[p + 1].ApplyToPoint(x) -
                 flip.cwiseProduct(core.pose_transforms[p].ApplyToPoint(flip.cwiseProduct(x))))
                    .norm(),
                1e-9)
          << names[p + 1] << " vertex " << v;
    }
  }
  EXPECT_GT(LargestBoneMotion(model, 0, 4), 1e-3);
  double apart = 0.0;
  for (int v : core.vertices) {
    const Eigen::Vector3d x = model.mesh.vertices.col(v);
    apart = std::max(apart, (core.pose_transforms[5].ApplyToPoint(x) -
                             core.pose_transforms[4].ApplyToPoint(x)).norm());
  }
  EXPECT_GT(apart, 1e-3);
  for (int h : {4, 5}) {
    const RigidTransform& half = core.pose_transforms[h];
    const RigidTransform& whole = core.pose_transforms[h - 2];
    for (int v : core.vertices) {
      const Eigen::Vector3d x = model.mesh.vertices.col(v);
      EXPECT_LT((half.ApplyToPoint(half.ApplyToPoint(x)) - whole.ApplyToPoint(x)).norm(), 1e-9)
          << names[h] << " vertex " << v;
    }
    const Eigen::Matrix3Xd blend =
        model.neutral.vertices + 0.5 * (model.poses[h - 2].surface - model.neutral.vertices);
    EXPECT_LT((model.poses[h].surface - blend).cwiseAbs().maxCoeff(), 1e-12) << names[h];
    EXPECT_LT(model.poses[h].embedding_mean_error, 0.05) << names[h];
  }
  EXPECT_NE(log.str().find("pose2: halfway pose half_pose2"), std::string::npos) << log.str();
  EXPECT_EQ(log.str().find("half_pose0"), std::string::npos) << log.str();
  // Kept as it is by a rerun of the same options.
  PrepareJobOptions keep = options;
  keep.keep_same_model = true;
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("kept, with its learned state"), std::string::npos) << log.str();
  // A run stopped after it wrote the model (its store as the snapshot) resumes with every
  // target, the halfway poses' too, taken from the store.
  std::filesystem::remove_all(options.output);
  std::filesystem::rename(g_snapshot, g_store);
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("6 of 6 poses' targets were taken from"), std::string::npos)
      << log.str();
  ActiveModel resumed;
  ASSERT_TRUE(LoadModel(options.output, &resumed, &error)) << error;
  for (int p = 0; p < 6; ++p) EXPECT_EQ(resumed.poses[p].target, model.poses[p].target);
  // Another threshold, above the twist's bone motion: no halfway pose, another model.
  keep.halfway.min_bone_motion = 0.5;
  log.str("");
  ASSERT_TRUE(RunPrepareJob(keep, log, &error)) << error;
  EXPECT_NE(log.str().find("is prepared anew"), std::string::npos) << log.str();
  ActiveModel without;
  ASSERT_TRUE(LoadModel(options.output, &without, &error)) << error;
  EXPECT_EQ(without.num_poses(), 4);
  EXPECT_EQ(without.bones[0].pose_transforms.size(), 4u);
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
  // Only the neutral itself, and a pose given twice (a copy under another name).
  options = options_;
  options.pose_paths = {options_.neutral};
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("every pose is the neutral surface"), std::string::npos) << error;
  ASSERT_FALSE(options_.pose_paths.empty());
  std::filesystem::copy_file(options_.pose_paths[0], dir_.File("copy.obj"),
                             std::filesystem::copy_options::overwrite_existing);
  options = options_;
  options.pose_paths.push_back(dir_.File("copy.obj"));
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("copy.obj: pose 'copy' is the same surface as pose"), std::string::npos)
      << error;
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
  SurfaceMesh lifted = patch;
  lifted.vertices(2, 2) = 0.1;
  ASSERT_TRUE(WriteObj(dir_.File("lifted.obj"), lifted, &error));
  options = options_;
  options.neutral = dir_.File("patch.obj");
  options.pose_paths = {dir_.File("lifted.obj")};
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("patch.obj"), std::string::npos) << error;
  EXPECT_NE(error.find("encloses"), std::string::npos) << error;
  // No fixed vertices.
  options = options_;
  options.boundary.fixed_depth = -1;
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("no simulation vertex is fixed"), std::string::npos) << error;
  // A fixed list that lists nothing is named (it said "no simulation vertex is fixed").
  std::ofstream(dir_.File("empty_list.txt")) << "# no vertices\n";
  options.boundary.fixed_list = dir_.File("empty_list.txt");
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_EQ(error, dir_.File("empty_list.txt") + ": lists no vertices");
  // A neutral at one point, and one whose size cubed no double holds (the messages named
  // a pose, or an open patch).
  for (const double scale : {0.0, 1e-110, 1e105}) {
    SurfaceMesh scaled = neutral_;
    scaled.vertices *= scale;
    ASSERT_TRUE(WriteObj(dir_.File("scaled.obj"), scaled, &error)) << error;
    options = options_;
    options.neutral = dir_.File("scaled.obj");
    options.pose_paths = {dir_.File("scaled.obj")};
    EXPECT_FALSE(RunPrepareJob(options, log, &error)) << scale;
    EXPECT_EQ(error.rfind(dir_.File("scaled.obj") +
                              ": the neutral surface's bounding-box diagonal is ",
                          0),
              0u)
        << error;
    EXPECT_NE(error.find(scale == 0.0 ? "(every vertex at one point)" : "beyond what doubles"),
              std::string::npos)
        << error;
  }
  // A missing neutral.
  options = options_;
  options.neutral = dir_.File("missing.obj");
  EXPECT_FALSE(RunPrepareJob(options, log, &error));
  EXPECT_NE(error.find("missing.obj: cannot open"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
