// Pose sets (prepare/pose_files.h): which files a specification names, and the names and
// surfaces read from them.

#include "prepare/pose_files.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/temp_dir.h"

namespace aqs {
namespace {

constexpr char kTriangle[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

TEST(PoseFilesTest, ResolvesFoldersListsAndExclusionsInOrder) {
  testing::TempDir dir;
  for (const char* name : {"b.obj", "a.obj", "a.teeth.obj"}) dir.Write(name, kTriangle);
  dir.Write("list.txt", "# a comment\nb\na.obj\n");
  std::vector<std::string> paths;
  std::string error;
  ASSERT_TRUE(ResolvePosePaths(dir.path(), "*.teeth.obj", &paths, &error)) << error;
  ASSERT_EQ(paths.size(), 2u);
  EXPECT_EQ(PoseNameFromPath(paths[0]), "a");
  EXPECT_EQ(PoseNameFromPath(paths[1]), "b");
  ASSERT_TRUE(ResolvePosePaths(dir.File("list.txt"), "", &paths, &error)) << error;
  ASSERT_EQ(paths.size(), 2u);
  EXPECT_EQ(PoseNameFromPath(paths[0]), "a");
  EXPECT_FALSE(ResolvePosePaths(dir.File("*.none"), "", &paths, &error));
}

// A name the model's text files cannot hold is refused naming the file, before the
// poses are read (a '#' made prepare write a model whose poses.txt could not be read).
TEST(PoseFilesTest, NamesTheModelFilesCannotHoldAreRefused) {
  testing::TempDir dir;
  std::vector<std::string> names;
  std::vector<Eigen::Matrix3Xd> surfaces;
  std::string error;
  for (const std::string bad : {"smile#2", "smile,2", "smile 2"}) {
    const std::string path = dir.Write(bad + ".obj", kTriangle);
    EXPECT_FALSE(ReadPoseSurfaces({path}, 3, 1, &names, &surfaces, &error)) << bad;
    EXPECT_EQ(error.rfind(path + ": the pose name (the file's name) '" + bad + "' contains", 0),
              0u)
        << error;
  }
  const std::string good = dir.Write("smile_2.obj", kTriangle);
  ASSERT_TRUE(ReadPoseSurfaces({good}, 3, 1, &names, &surfaces, &error)) << error;
  EXPECT_EQ(names, std::vector<std::string>{"smile_2"});
  EXPECT_FALSE(ReadPoseSurfaces({good, good}, 3, 1, &names, &surfaces, &error));
  EXPECT_NE(error.find("a second pose named 'smile_2'"), std::string::npos) << error;
  EXPECT_FALSE(ReadPoseSurfaces({good}, 4, 1, &names, &surfaces, &error));
  EXPECT_NE(error.find("3 vertices, but the neutral surface has 4"), std::string::npos) << error;
}

// A name longer than the file system allows is a message, not an uncaught
// std::filesystem::filesystem_error (std::filesystem::exists(path) throws on it).
TEST(PoseFilesTest, ANameTooLongIsAMessage) {
  testing::TempDir dir;
  const std::string good = dir.Write("a.obj", kTriangle);
  const std::string long_name = dir.File(std::string(300, 'n') + ".obj");
  std::vector<std::string> paths;
  std::string error;
  EXPECT_NO_THROW({
    if (ResolvePosePaths(good + "," + long_name, "", &paths, &error)) {
      std::vector<std::string> names;
      std::vector<Eigen::Matrix3Xd> surfaces;
      EXPECT_FALSE(ReadPoseSurfaces(paths, 3, 1, &names, &surfaces, &error));
    }
  });
  EXPECT_NE(error.find("File name too long"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
