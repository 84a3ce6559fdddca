// Latent files (io/latent_io.h): what aqs_fit writes reads back, and bad files name
// their line.

#include "io/latent_io.h"

#include <cmath>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "testing/temp_dir.h"

namespace aqs {
namespace {

TEST(LatentIoTest, WrittenFilesReadBackBitForBit) {
  testing::TempDir dir;
  const Eigen::VectorXd z = Eigen::VectorXd::Random(5) * 3.0;
  RigidTransform jaw;
  jaw.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  jaw.translation = Eigen::Vector3d(0.1, -0.2, 1.0 / 3.0);
  std::string error;
  ASSERT_TRUE(WriteLatentFile(dir.File("z.txt"), z, {"skull", "jaw"}, {RigidTransform(), jaw},
                              "a test", {"0123456789abcdef", "fedcba9876543210"}, &error))
      << error;
  Eigen::VectorXd read;
  std::vector<RigidTransform> bones;
  LatentFileModel origin;
  ASSERT_TRUE(
      ReadLatentFile(dir.File("z.txt"), 5, {"skull", "jaw"}, &read, &bones, &origin, &error))
      << error;
  EXPECT_EQ(read, z);
  EXPECT_EQ(origin.model, "0123456789abcdef");
  EXPECT_EQ(origin.learned, "fedcba9876543210");
  ASSERT_EQ(bones.size(), 2u);
  EXPECT_EQ(bones[1].rotation, jaw.rotation);
  EXPECT_EQ(bones[1].translation, jaw.translation);
  // A bone without a line stays at rest.
  // A file without a model line (written before there was one) has none.
  ASSERT_TRUE(ReadLatentFile(dir.Write("only.txt", "latent 1 2\n"), 2, {"jaw"}, &read, &bones,
                             &origin, &error))
      << error;
  EXPECT_TRUE(origin.model.empty() && origin.learned.empty());
  EXPECT_EQ(bones[0].rotation, Eigen::Matrix3d::Identity());
  EXPECT_EQ(bones[0].translation, Eigen::Vector3d::Zero());
}

// Non-finite numbers are refused naming the entry or bone, and nothing is written (the
// reader refuses nan and inf).
TEST(LatentIoTest, NonFiniteNumbersAreRefused) {
  testing::TempDir dir;
  Eigen::VectorXd z = Eigen::VectorXd::Zero(4);
  z[2] = std::numeric_limits<double>::quiet_NaN();
  std::string error;
  EXPECT_FALSE(WriteLatentFile(dir.File("z.txt"), z, {}, {}, "", {}, &error));
  EXPECT_NE(error.find("z.txt: latent entry 2 has a number that is not finite (nan)"),
            std::string::npos) << error;
  RigidTransform jaw;
  jaw.translation[1] = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(WriteLatentFile(dir.File("z.txt"), Eigen::VectorXd::Zero(4), {"skull", "jaw"},
                               {RigidTransform(), jaw}, "", {}, &error));
  EXPECT_NE(error.find("bone 1 column 3 has a number that is not finite (inf)"),
            std::string::npos) << error;
  EXPECT_FALSE(std::ifstream(dir.File("z.txt")).good());
}

TEST(LatentIoTest, BadFilesNameTheLine) {
  testing::TempDir dir;
  const std::string bone = "bone jaw 1 0 0 0 1 0 0 0 1 0 0 0\n";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"latent 1\n", "z.txt:1: expected 2 latent numbers"},
      {"latent 1 x\n", "z.txt:1: expected a number, got 'x'"},
      {"latent 1 2\nlatent 3 4\n", "z.txt:2: a second 'latent' line"},
      {"latent 1 2\n" + bone + bone, "z.txt:3: bone 'jaw' is given a second time"},
      {"latent 1 2\nbone skull 1 0 0 0 1 0 0 0 1 0 0 0\n", "z.txt:2: the model has no bone"},
      {"latent 1 2\nbone jaw 2 0 0 0 1 0 0 0 1 0 0 0\n", "is not a proper rotation"},
      {"latent 1 2\nbone jaw -1 0 0 0 1 0 0 0 1 0 0 0\n", "is not a proper rotation"},
      {"latent 1 2\nbone jaw 1 0 0\n", "z.txt:2: expected 'bone <name>' and 12 numbers"},
      {bone, "z.txt: no 'latent' line"},
      {"lat 1 2\n", "z.txt:1: expected a 'latent', 'bone' or 'model' line"},
      {"latent 1 2\nmodel 0123456789abcdef\n", "z.txt:2: expected 'model' and two fingerprints"},
      {"latent 1 2\nmodel 0123456789abcdef 0123456789ABCDEF\n", "z.txt:2: expected 'model'"},
      {"model 0123456789abcdef 0123456789abcdef\nmodel 0123456789abcdef 0123456789abcdef\n",
       "z.txt:2: a second 'model' line"},
  };
  for (const auto& [text, message] : cases) {
    Eigen::VectorXd z;
    std::vector<RigidTransform> bones;
    std::string error;
    EXPECT_FALSE(
        ReadLatentFile(dir.Write("z.txt", text), 2, {"jaw"}, &z, &bones, nullptr, &error))
        << text;
    EXPECT_NE(error.find(message), std::string::npos) << text << "\n" << error;
  }
}

}  // namespace
}  // namespace aqs
