// The fit prior: learned from the training latents and bone motions, centred on the
// neutral; its file round-trips, is learned when absent, and bad files name file:line.

#include "model/fit_prior.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "model/model_fingerprint.h"
#include "model/model_io.h"
#include "prepare/volumetric_targets.h"
#include "testing/synthetic_muscles.h"
#include "testing/temp_dir.h"
#include "train/pretrain.h"

namespace aqs {
namespace {

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// A pre-trained synthetic bar whose last pose is the neutral, with a bone "tip" that
// moves in every pose but the neutral.
ActiveModel ModelWithNeutralPose() {
  testing::SyntheticMuscles data = testing::MakeSyntheticMuscles(4, 0, 0.3, 5);
  ActiveModel model = data.model;
  TrainingPose neutral;
  neutral.name = "neutral";
  neutral.surface = model.neutral.vertices;
  model.poses.push_back(neutral);
  std::ostringstream log;
  std::string error;
  EXPECT_TRUE(MakeVolumetricTargets(VolumetricTargetOptions(), &model, log, &error)) << error;
  Bone bone;
  bone.name = "tip";
  bone.vertices = {model.mesh.num_vertices() - 1};
  for (int p = 0; p < model.num_poses(); ++p) {
    RigidTransform t;
    if (p + 1 < model.num_poses()) {
      t.rotation = Eigen::AngleAxisd(0.1 * (p + 1), Eigen::Vector3d::UnitZ()).toRotationMatrix();
      t.translation = Eigen::Vector3d(0.02 * p, -0.01 * p, 0.0);
    }
    bone.pose_transforms.push_back(t);
  }
  model.bones.push_back(bone);
  PretrainOptions pretrain;
  pretrain.spec.latent_dim = 3;
  pretrain.spec.hidden_dims = {6};
  pretrain.field.node_spacing = 0.5;
  pretrain.max_iterations = 5;
  pretrain.log_every = 0;
  PretrainReport report;
  EXPECT_TRUE(Pretrain(pretrain, &model, &report, log, &error)) << error;
  return model;
}

TEST(FitPriorTest, CentredOnTheNeutralWithTheTrainingSpread) {
  const ActiveModel model = ModelWithNeutralPose();
  const FitPriorOptions options;
  const FitPrior prior = LearnFitPrior(model, options);
  EXPECT_EQ(prior.center, "neutral");
  const int neutral = model.num_poses() - 1;
  EXPECT_EQ(prior.latent.mean, Eigen::VectorXd(model.latents.col(neutral)));
  // Latent covariance: the second moment about the neutral's latent plus the floor.
  const Eigen::MatrixXd centred = model.latents.colwise() - prior.latent.mean;
  Eigen::MatrixXd expected = centred * centred.transpose() / model.num_poses();
  expected.diagonal().array() += options.latent_floor * expected.trace() / model.latent_dim();
  EXPECT_LT((prior.latent.covariance - expected).norm(), 1e-12 * expected.norm());
  // W^T W is the inverse covariance.
  EXPECT_LT((prior.latent.whitening.transpose() * prior.latent.whitening * prior.latent.covariance -
             Eigen::MatrixXd::Identity(3, 3)).norm(), 1e-9);
  // The bone: mean at rest (the neutral's), z rotations spread, floors elsewhere.
  ASSERT_EQ(prior.bones.size(), 1u);
  EXPECT_LT(prior.bones[0].mean.norm(), 1e-15);
  const Eigen::MatrixXd& c = prior.bones[0].covariance;
  double rz = 0;
  for (int p = 0; p + 1 < model.num_poses(); ++p) rz += std::pow(0.1 * (p + 1), 2);
  rz /= model.num_poses();
  const double rotation_floor = std::max(options.rotation_floor, options.rotation_floor_fraction * std::sqrt(rz));
  EXPECT_NEAR(c(2, 2), rz + rotation_floor * rotation_floor, 1e-12);
  EXPECT_NEAR(c(0, 0), rotation_floor * rotation_floor, 1e-12);
  EXPECT_GT(c(1, 1), 0.0);
  // The whole 6 x 6 covariance: the second moment of the motions' parameters (z rotation
  // 0.1 (p + 1), translation (0.02 p, -0.01 p, 0); the neutral at rest) about the
  // neutral's, plus the rotation floor and the translation floor, the larger of a
  // fraction of the largest translation deviation and 1e-3 of the mesh's diagonal.
  Eigen::MatrixXd moment = Eigen::MatrixXd::Zero(6, 6);
  for (int p = 0; p + 1 < model.num_poses(); ++p) {
    Eigen::Matrix<double, 6, 1> q;
    q << 0.0, 0.0, 0.1 * (p + 1), 0.02 * p, -0.01 * p, 0.0;
    moment += q * q.transpose() / model.num_poses();
  }
  const double diagonal =
      (model.mesh.vertices.rowwise().maxCoeff() - model.mesh.vertices.rowwise().minCoeff()).norm();
  const double translation_floor =
      std::max(options.translation_floor_fraction *
                   std::sqrt(moment.diagonal().tail<3>().maxCoeff()),
               1e-3 * diagonal);
  Eigen::MatrixXd expected_bone = moment;
  for (int i = 0; i < 3; ++i) {
    expected_bone(i, i) += rotation_floor * rotation_floor;
    expected_bone(3 + i, 3 + i) += translation_floor * translation_floor;
  }
  EXPECT_LT((c - expected_bone).cwiseAbs().maxCoeff(), 1e-12) << c << "\n" << expected_bone;
  EXPECT_GT(translation_floor, 1e-3 * diagonal) << "the fraction's branch";
}

// A bone that only turns: its translation variances are the floor of 1e-3 of the mesh's
// bounding-box diagonal (squared).
TEST(FitPriorTest, ABoneThatOnlyTurnsHasTheMeshFloorOnItsTranslation) {
  ActiveModel model = ModelWithNeutralPose();
  for (RigidTransform& t : model.bones[0].pose_transforms) t.translation.setZero();
  const FitPrior prior = LearnFitPrior(model, FitPriorOptions());
  const double diagonal =
      (model.mesh.vertices.rowwise().maxCoeff() - model.mesh.vertices.rowwise().minCoeff()).norm();
  const Eigen::MatrixXd& c = prior.bones[0].covariance;
  for (int i = 3; i < 6; ++i) {
    EXPECT_NEAR(c(i, i), std::pow(1e-3 * diagonal, 2), 1e-15) << i;
  }
}

// No prior from a model without poses, or from latents or bone motions so far apart
// that their second moment overflows: false with the reason (it aborted in a CHECK).
TEST(FitPriorTest, OptionsNameTheBadField) {
  std::string error;
  FitPriorOptions options;
  EXPECT_TRUE(options.Validate(&error)) << error;
  options.rotation_floor = -0.01;
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("rotation_floor", 0), 0u) << error;
  options = FitPriorOptions();
  options.latent_floor = std::nan("");
  EXPECT_FALSE(options.Validate(&error));
  EXPECT_EQ(error.rfind("latent_floor", 0), 0u) << error;
}

TEST(FitPriorTest, NoPriorFromNoPosesOrOverflowingSpreads) {
  const ActiveModel model = ModelWithNeutralPose();
  FitPrior prior;
  std::string error;
  ASSERT_TRUE(LearnFitPrior(model, FitPriorOptions(), &prior, &error)) << error;
  ActiveModel far_bone = model;
  far_bone.bones[0].pose_transforms[0].translation.x() = 1e200;
  EXPECT_FALSE(LearnFitPrior(far_bone, FitPriorOptions(), &prior, &error));
  EXPECT_EQ(error.rfind("the motions of bone 'tip' are too far apart", 0), 0u) << error;
  ActiveModel far_latent = model;
  far_latent.latents(0, 1) = 1e200;
  EXPECT_FALSE(LearnFitPrior(far_latent, FitPriorOptions(), &prior, &error));
  EXPECT_EQ(error.rfind("the training latents are too far apart", 0), 0u) << error;
  ActiveModel no_poses = model;
  no_poses.poses.clear();
  no_poses.latents.resize(model.latent_dim(), 0);
  EXPECT_FALSE(LearnFitPrior(no_poses, FitPriorOptions(), &prior, &error));
  EXPECT_EQ(error, "the model has no training poses to learn a fit prior from");
}

TEST(FitPriorTest, LatentsWithoutSpreadGiveUnitVarianceNotAPin) {
  FitPriorOptions options;
  GaussianPrior prior;
  std::string error;
  // One training pose: no spread about it (the covariance was 1e-14 I, which pinned every
  // fit to that latent).
  Eigen::MatrixXd one(3, 1);
  one.col(0) = Eigen::Vector3d(0.5, -1.0, 2.0);
  ASSERT_TRUE(LearnLatentPrior(one, 0, options, &prior, &error)) << error;
  EXPECT_TRUE(prior.mean.isApprox(one.col(0)));
  EXPECT_TRUE(prior.covariance.isApprox((1.0 + options.latent_floor) *
                                        Eigen::MatrixXd::Identity(3, 3)))
      << prior.covariance;
  // Latents all alike, centred on their mean: the same.
  const Eigen::MatrixXd alike = one.replicate(1, 4);
  ASSERT_TRUE(LearnLatentPrior(alike, -1, options, &prior, &error)) << error;
  EXPECT_NEAR(prior.covariance(1, 1), 1.0 + options.latent_floor, 1e-12);
  EXPECT_NEAR(prior.SquaredMahalanobis(one.col(0) + Eigen::Vector3d(1, 0, 0)),
              1.0 / (1.0 + options.latent_floor), 1e-9);
  // A small but real spread is kept as it is.
  Eigen::MatrixXd small = alike;
  small(0, 1) += 1e-3;
  small(0, 2) -= 1e-3;
  ASSERT_TRUE(LearnLatentPrior(small, -1, options, &prior, &error)) << error;
  EXPECT_LT(prior.covariance(0, 0), 1e-5);
  // Non-finite latents are still refused, not taken for latents without spread.
  Eigen::MatrixXd bad = alike;
  bad(2, 3) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(LearnLatentPrior(bad, -1, options, &prior, &error));
  EXPECT_EQ(error.rfind("the training latents are too far apart", 0), 0u) << error;
}

// SetCovariance takes symmetric positive definite matrices only (up to round-off of
// 1e-9 relative), and leaves the prior as it was when it refuses one.
TEST(FitPriorTest, SetCovarianceRefusesAsymmetricIndefiniteAndMisshapenMatrices) {
  GaussianPrior prior;
  prior.mean = Eigen::VectorXd::Zero(3);
  Eigen::MatrixXd c(3, 3);
  c << 2.0, 0.3, 0.1,
       0.3, 1.0, 0.2,
       0.1, 0.2, 0.5;
  ASSERT_TRUE(prior.SetCovariance(c));
  EXPECT_LT((prior.whitening.transpose() * prior.whitening * c -
             Eigen::MatrixXd::Identity(3, 3)).cwiseAbs().maxCoeff(), 1e-12);
  Eigen::MatrixXd asymmetric = c;
  asymmetric(0, 2) += 1e-6;
  EXPECT_FALSE(prior.SetCovariance(asymmetric));
  EXPECT_EQ(prior.covariance, c);
  Eigen::MatrixXd round_off = c;
  round_off(0, 2) += 1e-12;
  EXPECT_TRUE(prior.SetCovariance(round_off));
  Eigen::MatrixXd indefinite = c;
  indefinite(2, 2) = -0.5;
  EXPECT_FALSE(prior.SetCovariance(indefinite));
  EXPECT_FALSE(prior.SetCovariance(Eigen::MatrixXd::Identity(2, 2)));
}

TEST(FitPriorTest, FileRoundTripsIsLearnedWhenAbsentAndBadFilesNameTheLine) {
  const ActiveModel model = ModelWithNeutralPose();
  testing::TempDir dir;
  std::string error;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  ASSERT_TRUE(std::filesystem::exists(path + "/learned/prior.txt"));
  const FitPrior learned = LearnFitPrior(model);
  ActiveModel back;
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
  EXPECT_EQ(back.fit_prior.center, "neutral");
  EXPECT_EQ(back.fit_prior.latent.mean, learned.latent.mean);
  EXPECT_EQ(back.fit_prior.latent.covariance, learned.latent.covariance);
  EXPECT_EQ(back.fit_prior.bones[0].covariance, learned.bones[0].covariance);
  // A model saved before priors existed: learned at load, the same.
  std::filesystem::remove(path + "/learned/prior.txt");
  ActiveModel old;
  ASSERT_TRUE(LoadModel(path, &old, &error)) << error;
  EXPECT_EQ(old.fit_prior.latent.covariance, learned.latent.covariance);
  EXPECT_EQ(old.fit_prior.bones[0].mean, learned.bones[0].mean);
  // Damaged files.
  const std::vector<std::string> names = {"tip"};
  FitPrior bad = learned;
  bad.latent.covariance(0, 0) = -1.0;  // not positive definite (written as is)
  ASSERT_TRUE(WriteFitPrior(path + "/learned/prior.txt", bad, names, &error)) << error;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt:7: the covariance of the latent is not symmetric positive definite"),
            std::string::npos) << error;
  // Not symmetric (written as is; the reader must not symmetrise it silently).
  bad = learned;
  bad.latent.covariance(0, 1) += 0.5 * std::sqrt(bad.latent.covariance(0, 0) *
                                                 bad.latent.covariance(1, 1));
  ASSERT_TRUE(WriteFitPrior(path + "/learned/prior.txt", bad, names, &error)) << error;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt:7: the covariance of the latent is not symmetric "
                       "positive definite"),
            std::string::npos) << error;
  ASSERT_TRUE(WriteFitPrior(path + "/learned/prior.txt", learned, names, &error)) << error;
  std::ofstream(path + "/learned/prior.txt", std::ios::app) << "bone jaw mean 0 0 0 0 0 0\n";
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt:15: the model has no bone 'jaw'"), std::string::npos) << error;
  ASSERT_TRUE(WriteFitPrior(path + "/learned/prior.txt", learned, names, &error)) << error;
  std::ofstream(path + "/learned/prior.txt", std::ios::app) << "latent_mean 1 2\n";
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt:15: expected 3 finite numbers"), std::string::npos) << error;
  // A line given twice: the second replaced the first silently.
  for (const std::string& line : {std::string("latent_mean 1 2 3"),
                                  std::string("latent_covariance 01 1 0 0"),
                                  std::string("bone tip mean 0 0 0 0 0 0"),
                                  std::string("center -")}) {
    SCOPED_TRACE(line);
    ASSERT_TRUE(WriteFitPrior(path + "/learned/prior.txt", learned, names, &error)) << error;
    std::ofstream(path + "/learned/prior.txt", std::ios::app) << line << "\n";
    EXPECT_FALSE(LoadModel(path, &back, &error));
    EXPECT_NE(error.find("prior.txt:15: a second '"), std::string::npos) << error;
    EXPECT_NE(error.find("(the first is line "), std::string::npos) << error;
  }
  // Finite but absurd priors (every fit failed inside Ceres, naming nothing).
  FitPrior far = learned;
  far.bones[0].mean[3] = 1e300;
  ASSERT_TRUE(WriteFitPrior(path + "/learned/prior.txt", far, names, &error)) << error;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt: the mean motion of bone 'tip' turns by more than 2 pi or "
                       "moves more than 1000 model sizes"),
            std::string::npos)
      << error;
  FitPrior pinned = learned;
  ASSERT_TRUE(pinned.latent.SetCovariance(
      1e-300 * Eigen::MatrixXd::Identity(pinned.latent.size(), pinned.latent.size())));
  ASSERT_TRUE(WriteFitPrior(path + "/learned/prior.txt", pinned, names, &error)) << error;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt: the latent covariance's mean variance is 1e-300, below 1e-14"),
            std::string::npos)
      << error;
  pinned = learned;
  Eigen::MatrixXd bone_covariance = pinned.bones[0].covariance;
  bone_covariance(4, 4) = 1e-300;
  bone_covariance.row(4).setZero();
  bone_covariance.col(4).setZero();
  bone_covariance(4, 4) = 1e-300;
  ASSERT_TRUE(pinned.bones[0].SetCovariance(bone_covariance));
  ASSERT_TRUE(WriteFitPrior(path + "/learned/prior.txt", pinned, names, &error)) << error;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("the covariance of bone 'tip' has a variance near 0"), std::string::npos)
      << error;
  ASSERT_TRUE(WriteFitPrior(path + "/learned/prior.txt", learned, names, &error)) << error;
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
}

// The model readers' boundaries, each a single comparison (a third mutation review,
// 2026-12-08: with `<=` for `<` an embedding element equal to the element count aborted the
// load, and a covariance row index equal to the latent size corrupted the heap): the
// prior's centre must be a training pose, its rows complete and in range, and an
// embedding's elements in [0, elements).
TEST(FitPriorFileTest, BoundariesOfThePriorAndTheEmbeddingAreRefusedNamingThem) {
  const ActiveModel model = ModelWithNeutralPose();
  testing::TempDir dir;
  std::string error;
  const std::string path = dir.File("m");
  ASSERT_TRUE(SaveModel(path, model, &error)) << error;
  const std::string prior = path + "/learned/prior.txt";
  const std::string original = ReadText(prior);
  ActiveModel back;
  auto with_prior = [&](const std::string& text) { std::ofstream(prior, std::ios::trunc) << text; };
  auto replaced = [&](const std::string& from, const std::string& to) {
    std::string text = original;
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    return text;
  };
  auto without_line = [&](const std::string& start) {
    std::string text = original;
    const size_t at = text.find(start);
    EXPECT_NE(at, std::string::npos) << start;
    if (at != std::string::npos) text.erase(at, text.find('\n', at) - at + 1);
    return text;
  };
  with_prior(replaced("latent_covariance 2 ", "latent_covariance 3 "));  // latent size 3
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("covariance row index must be in [0, 3)"), std::string::npos) << error;
  with_prior(without_line("center "));
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt: no 'center' line"), std::string::npos) << error;
  with_prior(without_line("latent_covariance 1 "));
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("prior.txt: the latent needs its mean and every covariance row"),
            std::string::npos)
      << error;
  with_prior(replaced("center neutral", "center nosuch"));
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("the priors are centred on 'nosuch', which is not a training pose"),
            std::string::npos)
      << error;
  with_prior(original);
  ASSERT_TRUE(LoadModel(path, &back, &error)) << error;
  // The first embedding line's element set to the element count.
  const std::string embedding = path + "/embedding.txt";
  std::string text = ReadText(embedding);
  size_t at = 0;
  while (text[at] == '#') at = text.find('\n', at) + 1;
  text = text.substr(0, at) + std::to_string(model.mesh.num_tets()) +
         text.substr(text.find(' ', at));
  std::ofstream(embedding, std::ios::trunc) << text;
  EXPECT_FALSE(LoadModel(path, &back, &error));
  EXPECT_NE(error.find("expected '<element in [0, " + std::to_string(model.mesh.num_tets()) + ")>"),
            std::string::npos)
      << error;
}

// What the model's fingerprint and validation see, and how bones drive their own vertices
// (no test model had mu differing per element, a vertex fixed twice, or two bones).
TEST(ModelFingerprintTest, SeesMuAndSavingRefusesAVertexFixedTwiceAndBonesMoveTheirOwn) {
  const ActiveModel model = ModelWithNeutralPose();
  ActiveModel stiffer = model;
  stiffer.mu[0] *= 2.0;
  EXPECT_NE(ModelFingerprint(stiffer), ModelFingerprint(model));
  ActiveModel twice = model;
  ASSERT_FALSE(twice.static_vertices.empty());
  ASSERT_FALSE(twice.bones.empty());
  twice.bones[0].vertices.push_back(twice.static_vertices[0]);
  testing::TempDir dir;
  std::string error;
  EXPECT_FALSE(SaveModel(dir.File("t"), twice, &error));
  EXPECT_NE(error.find("is fixed twice"), std::string::npos) << error;
  // A second bone, lifted by 0.5 in every pose, moves its own vertex by its own motion.
  ActiveModel two = model;
  Bone second;
  second.name = "second";
  second.vertices = {two.mesh.num_vertices() - 2};
  for (int p = 0; p < two.num_poses(); ++p) {
    RigidTransform t;
    t.translation = Eigen::Vector3d(0.0, 0.0, 0.5);
    second.pose_transforms.push_back(t);
  }
  two.bones.push_back(second);
  const BoundaryConditions bc = PoseBoundaryConditions(two, 0);
  const int v = two.mesh.num_vertices() - 2;
  const auto k = std::find(bc.vertices.begin(), bc.vertices.end(), v) - bc.vertices.begin();
  ASSERT_LT(k, static_cast<long>(bc.vertices.size()));
  EXPECT_LT((bc.positions.col(k) - (two.mesh.vertices.col(v) + Eigen::Vector3d(0, 0, 0.5))).norm(),
            1e-12);
}

}  // namespace
}  // namespace aqs
