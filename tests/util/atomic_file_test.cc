#include "util/atomic_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "testing/file_contents.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

using testing::ReadAll;

TEST(AtomicFileTest, CommitReplacesAndAbandonLeavesOldContent) {
  testing::TempDir dir;
  const std::string path = dir.Write("out.txt", "old");
  {
    AtomicFileWriter writer(path);
    writer.stream() << "half written";
    // No commit: destroyed as if the program stopped early.
  }
  EXPECT_EQ(ReadAll(path), "old");
  std::string error;
  ASSERT_TRUE(WriteFileAtomically(path, "new", &error)) << error;
  EXPECT_EQ(ReadAll(path), "new");
  int files = 0;
  for (const auto& entry : std::filesystem::directory_iterator(dir.path())) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1) << "temporary files left behind";
}

TEST(AtomicFileTest, UnwritableDirectoryIsAnError) {
  std::string error;
  EXPECT_FALSE(WriteFileAtomically("/nonexistent/dir/x.txt", "a", &error));
  EXPECT_NE(error.find("/nonexistent/dir/x.txt"), std::string::npos);
}

}  // namespace
}  // namespace aqs
