#include "util/path_lock.h"

#include <signal.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>

#include "testing/fault_kill.h"
#include "testing/file_contents.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

using testing::ReadAll;

// Tries to take the lock of `path` in a child process; returns its error message ("" if
// it got the lock).
std::string ErrorOfOtherProcess(const testing::TempDir& dir, const std::string& path) {
  const std::string out = dir.File("child_error.txt");
  testing::RunInChildKilledAt(-1, [&] {
    PathLock lock;
    std::string error;
    lock.Acquire(path, &error, "model M");
    std::ofstream(out) << error;
    return true;
  });
  return ReadAll(out);
}

TEST(PathLockTest, SecondProcessIsRefusedNamingTheHolder) {
  testing::TempDir dir;
  const std::string path = dir.File("model");
  const std::string lock_file = PathLock::LockFileOf(path);
  EXPECT_EQ(fs::path(lock_file).filename(), "model.aqs-lock");
  PathLock lock;
  std::string error;
  ASSERT_TRUE(lock.Acquire(path, &error)) << error;
  EXPECT_TRUE(lock.first());
  EXPECT_NE(ReadAll(lock_file).find("pid " + std::to_string(getpid()) + "\n"), std::string::npos);
  const std::string refused = ErrorOfOtherProcess(dir, path + "/");  // same model, other spelling
  EXPECT_EQ(refused, "model M is in use by process " + std::to_string(getpid()) + " (lock file " +
                         lock_file + ")");
  // Shared within the process.
  {
    PathLock again;
    ASSERT_TRUE(again.Acquire(dir.path() + "/./model", &error)) << error;
    EXPECT_FALSE(again.first());
  }
  EXPECT_TRUE(fs::exists(lock_file));
  lock.Release();
  EXPECT_FALSE(fs::exists(lock_file));
  EXPECT_EQ(ErrorOfOtherProcess(dir, path), "");
}

TEST(PathLockTest, LockFileOfAKilledProcessIsTakenOver) {
  testing::TempDir dir;
  const std::string path = dir.File("model");
  ASSERT_EQ(testing::RunInChildKilledAt(0, [&] {
              PathLock lock;
              std::string error;
              if (!lock.Acquire(path, &error)) return false;
              ::raise(SIGKILL);
              return true;
            }),
            "killed");
  EXPECT_TRUE(fs::exists(PathLock::LockFileOf(path)));  // left behind, unlocked
  PathLock lock;
  std::string error;
  ASSERT_TRUE(lock.Acquire(path, &error)) << error;
  EXPECT_NE(ReadAll(PathLock::LockFileOf(path)).find("pid " + std::to_string(getpid())),
            std::string::npos);
}

TEST(PathLockTest, ForeignFileUnderTheLockNameIsNotTouched) {
  testing::TempDir dir;
  const std::string path = dir.File("model");
  dir.Write("model.aqs-lock", "my notes");
  PathLock lock;
  std::string error;
  EXPECT_FALSE(lock.Acquire(path, &error));
  EXPECT_NE(error.find("is not an ActiveQS lock file"), std::string::npos) << error;
  EXPECT_EQ(ReadAll(dir.File("model.aqs-lock")), "my notes");
}

}  // namespace
}  // namespace aqs
