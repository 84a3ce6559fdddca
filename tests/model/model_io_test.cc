#include "model/model_io.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "prepare/volumetric_targets.h"
#include "testing/temp_dir.h"
#include "train/pretrain.h"
#include "train/synthetic_muscles.h"

namespace aqs {
namespace {

ActiveModel TrainedSyntheticModel() {
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(3, 0, 0.3, 5);
  ActiveModel& model = data.model;
  std::ostringstream log;
  std::string error;
  EXPECT_TRUE(MakeVolumetricTargets(VolumetricTargetOptions(), &model, log, &error)) << error;
  // A bone on the free end, with a transform per pose, to cover bones in the files.
  Bone bone;
  bone.name = "tip";
  bone.vertices = {model.mesh.num_vertices() - 1};
  for (int p = 0; p < model.num_poses(); ++p) {
    RigidTransform t;
    t.translation = Eigen::Vector3d(0.01 * p, 0, 0);
    bone.pose_transforms.push_back(t);
  }
  model.bones.push_back(bone);
  PretrainOptions pretrain;
  pretrain.spec.latent_dim = 2;
  pretrain.spec.hidden_dims = {6};
  pretrain.field.node_spacing = 0.5;
  pretrain.max_iterations = 5;
  pretrain.log_every = 0;
  PretrainReport report;
  EXPECT_TRUE(Pretrain(pretrain, &model, &report, log, &error)) << error;
  model.states.assign(model.num_poses(), Eigen::Matrix3Xd());
  model.states[1] = model.mesh.vertices * 1.01;
  return data.model;
}

TEST(ModelIoTest, RoundTripIsExact) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;  // replaces an existing model
  ActiveModel back;
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
  EXPECT_EQ(back.mesh.vertices, model.mesh.vertices);
  EXPECT_EQ(back.mesh.tets, model.mesh.tets);
  EXPECT_EQ(back.mu, model.mu);
  EXPECT_EQ(back.static_vertices, model.static_vertices);
  ASSERT_EQ(back.bones.size(), 1u);
  EXPECT_EQ(back.bones[0].name, "tip");
  EXPECT_EQ(back.bones[0].vertices, model.bones[0].vertices);
  EXPECT_EQ(back.bones[0].pose_transforms[2].translation, model.bones[0].pose_transforms[2].translation);
  EXPECT_EQ(back.embedding.element, model.embedding.element);
  EXPECT_EQ(back.embedding.weights, model.embedding.weights);
  EXPECT_EQ(back.embedding.offsets, model.embedding.offsets);
  ASSERT_EQ(back.num_poses(), model.num_poses());
  for (int p = 0; p < model.num_poses(); ++p) {
    EXPECT_EQ(back.poses[p].name, model.poses[p].name);
    EXPECT_EQ(back.poses[p].surface, model.poses[p].surface);
    EXPECT_EQ(back.poses[p].target, model.poses[p].target);
    EXPECT_EQ(back.poses[p].embedding_max_error, model.poses[p].embedding_max_error);
  }
  ASSERT_TRUE(back.decoder != nullptr);
  EXPECT_EQ(back.decoder_params, model.decoder_params);
  EXPECT_EQ(back.latents, model.latents);
  EXPECT_EQ(back.states[1], model.states[1]);
  EXPECT_EQ(back.states[0].cols(), 0);
  // Decoding gives the same actuation.
  ActuationMatrix a, b;
  DecoderWorkspace w;
  model.decoder->Decode(model.decoder_params.data(), model.latents.col(0), &a, &w);
  back.decoder->Decode(back.decoder_params.data(), back.latents.col(0), &b, &w);
  EXPECT_EQ(a, b);
  // No temporary directories are left behind.
  int entries = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    (void)entry;
    ++entries;
  }
  EXPECT_EQ(entries, 1);
}

TEST(ModelIoTest, DamagedModelsFailNamingTheFile) {
  const ActiveModel model = TrainedSyntheticModel();
  testing::TempDir dir;
  std::string error;
  ActiveModel back;
  EXPECT_FALSE(LoadModel(dir.File("nothing"), &back, &error));
  EXPECT_NE(error.find("model.txt"), std::string::npos) << error;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  std::filesystem::remove(path + "/poses/0001.bin");
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("poses/0001.bin"), std::string::npos) << error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  {
    std::ofstream out(path + "/embedding.txt", std::ios::app);
    out << "3 0.25 0.25 0.25 0.25 0 0 0 0\n";  // one line too many
  }
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("embedding.txt:"), std::string::npos) << error;
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  {
    std::ofstream out(path + "/fixed.txt", std::ios::app);
    out << "0 7\n";  // bone 7 does not exist
  }
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("refers to bone 7"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
