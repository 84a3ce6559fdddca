// File lists (util/file_list.h): folders, globs, list files and comma lists.

#include "util/file_list.h"

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/temp_dir.h"

namespace aqs {
namespace {

std::vector<std::string> Paths(const std::vector<ListedFile>& files) {
  std::vector<std::string> paths;
  for (const ListedFile& file : files) paths.push_back(file.path);
  return paths;
}

TEST(FileListTest, FoldersAndGlobsAreSortedByName) {
  testing::TempDir dir;
  for (const char* name : {"b.obj", "a.OBJ", "c.ply", "notes.md"}) dir.Write(name, "x");
  FileListOptions options;
  options.folder_extensions = {".obj", ".ply"};
  std::vector<ListedFile> files;
  std::string error;
  ASSERT_TRUE(ResolveFileList(dir.path(), options, &files, &error)) << error;
  EXPECT_EQ(Paths(files), (std::vector<std::string>{dir.File("a.OBJ"), dir.File("b.obj"),
                                                    dir.File("c.ply")}));
  EXPECT_EQ(files[0].origin, files[0].path);
  ASSERT_TRUE(ResolveFileList(dir.File("*.obj"), options, &files, &error)) << error;
  EXPECT_EQ(Paths(files), (std::vector<std::string>{dir.File("b.obj")}));
  ASSERT_TRUE(ResolveFileList(dir.File("*.none"), options, &files, &error)) << error;
  EXPECT_TRUE(files.empty());
}

TEST(FileListTest, ListFilesKeepTheirOrderAndNameTheirLines) {
  testing::TempDir dir;
  dir.Write("b.obj", "x");
  dir.Write("a.obj", "x");
  dir.Write("list.txt", "# poses\nb.obj\n\na  # no extension\n");
  FileListOptions options;
  options.default_extension = ".obj";
  options.what = "pose file";
  std::vector<ListedFile> files;
  std::string error;
  ASSERT_TRUE(ResolveFileList(dir.File("list.txt"), options, &files, &error)) << error;
  EXPECT_EQ(Paths(files), (std::vector<std::string>{dir.File("b.obj"), dir.File("a.obj")}));
  EXPECT_EQ(files[1].origin, dir.File("list.txt") + ":4");
  // Relative to another folder.
  options.base_dir = "/nonexistent";
  EXPECT_FALSE(ResolveFileList(dir.File("list.txt"), options, &files, &error));
  EXPECT_NE(error.find("list.txt:2: pose file '/nonexistent/b.obj' does not exist"),
            std::string::npos)
      << error;
  dir.Write("two.txt", "a.obj b.obj\n");
  EXPECT_FALSE(ResolveFileList(dir.File("two.txt"), options, &files, &error));
  EXPECT_NE(error.find("two.txt:1: expected one pose file per line"), std::string::npos) << error;
}

TEST(FileListTest, CommaListsKeepTheirOrderAndMustExist) {
  testing::TempDir dir;
  dir.Write("b.txt", "x");
  dir.Write("a.txt", "x");
  FileListOptions options;
  options.what = "target file";
  std::vector<ListedFile> files;
  std::string error;
  // Two .txt paths with a comma: a list of files, not a list file.
  ASSERT_TRUE(ResolveFileList(dir.File("b.txt") + "," + dir.File("a.txt"), options, &files,
                              &error))
      << error;
  EXPECT_EQ(Paths(files), (std::vector<std::string>{dir.File("b.txt"), dir.File("a.txt")}));
  EXPECT_FALSE(ResolveFileList(dir.File("a.txt") + "," + dir.File("c.txt"), options, &files,
                               &error));
  EXPECT_EQ(error, "target file '" + dir.File("c.txt") + "' does not exist");
}

}  // namespace
}  // namespace aqs
