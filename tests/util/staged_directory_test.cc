#include "util/staged_directory.h"

#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>

#include "testing/fault_kill.h"
#include "testing/file_contents.h"
#include "testing/temp_dir.h"
#include "util/atomic_file.h"

namespace aqs {
namespace {

namespace fs = std::filesystem;

using testing::ReadAll;

std::set<std::string> Entries(const std::string& dir) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) names.insert(entry.path().filename());
  return names;
}

// A "unit" directory: id.txt (its identity file) naming the version, and a subfolder.
void WriteUnit(const std::string& dir, const std::string& version) {
  fs::create_directories(dir + "/sub");
  std::ofstream(dir + "/sub/data.txt") << version << " data";
  std::ofstream(dir + "/id.txt") << version;
}

// Stages version "new" and installs it at `target`.
bool ReplaceUnit(const std::string& target) {
  std::string error, warning;
  const std::string staging = StagingPathOf(target);
  if (!CreateStagingDirectory(staging, &error)) return false;
  WriteUnit(staging, "new");
  return InstallStagingDirectory(staging, target, &warning, &error) && warning.empty();
}

TEST(StagedDirectoryTest, InstallsIntoMissingEmptyAndExistingTargets) {
  for (bool exchange : {true, false}) {
    DisableExchangeForTesting(!exchange);
    testing::TempDir dir;
    const std::string target = dir.File("unit");
    ASSERT_TRUE(ReplaceUnit(target));  // missing
    EXPECT_EQ(ReadAll(target + "/id.txt"), "new");
    EXPECT_FALSE(fs::exists(target + "/" + kTemporaryMarker));
    fs::remove_all(target);
    fs::create_directory(target);
    ASSERT_TRUE(ReplaceUnit(target));  // empty directory
    EXPECT_EQ(ReadAll(target + "/id.txt"), "new");
    fs::remove_all(target);
    WriteUnit(target, "old");
    ASSERT_TRUE(ReplaceUnit(target));  // an existing unit
    EXPECT_EQ(ReadAll(target + "/id.txt"), "new");
    EXPECT_EQ(ReadAll(target + "/sub/data.txt"), "new data");
    EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"unit"})) << "exchange " << exchange;
  }
  DisableExchangeForTesting(false);
}

// Something that is not an ActiveQS temporary at this process's staging path (a user's
// folder or file of that name) is refused and kept; an empty directory, or a leftover
// with the marker, is replaced by a fresh staging directory.
TEST(StagedDirectoryTest, AForeignEntryAtTheStagingPathIsRefusedAndKept) {
  testing::TempDir dir;
  const std::string staging = StagingPathOf(dir.File("unit"));
  std::string error;
  fs::create_directory(staging);
  std::ofstream(staging + "/mine.txt") << "my data";
  EXPECT_FALSE(CreateStagingDirectory(staging, &error));
  EXPECT_EQ(error, staging + " exists and is not an ActiveQS temporary directory");
  EXPECT_EQ(ReadAll(staging + "/mine.txt"), "my data");
  fs::remove_all(staging);
  std::ofstream(staging) << "a file";
  EXPECT_FALSE(CreateStagingDirectory(staging, &error));
  EXPECT_EQ(error, staging + " exists and is not an ActiveQS temporary directory");
  EXPECT_EQ(ReadAll(staging), "a file");
  fs::remove(staging);
  fs::create_directory(staging);  // empty: replaced
  ASSERT_TRUE(CreateStagingDirectory(staging, &error)) << error;
  EXPECT_EQ(Entries(staging), std::set<std::string>({kTemporaryMarker}));
  std::ofstream(staging + "/half_written.txt") << "from a killed run";  // with the marker
  ASSERT_TRUE(CreateStagingDirectory(staging, &error)) << error;
  EXPECT_EQ(Entries(staging), std::set<std::string>({kTemporaryMarker}));
}

// A process killed at any step of a replacement leaves the old or the new unit at the
// target (or, without RENAME_EXCHANGE, a moved-aside one that CleanLeftovers renames
// back), and CleanLeftovers then removes everything else.
TEST(StagedDirectoryTest, KillAtEveryStepLeavesOldOrNewAndCleanupRemovesTheRest) {
  for (bool exchange : {true, false}) {
    DisableExchangeForTesting(!exchange);
    testing::TempDir dir;
    const std::string target = dir.File("unit");
    WriteUnit(target, "old");
    const std::vector<std::string> points = testing::FaultPointsOf([&] { ReplaceUnit(target); });
    ASSERT_GE(points.size(), 5u);
    std::set<std::string> seen;
    for (int n = 0; n < static_cast<int>(points.size()); ++n) {
      SCOPED_TRACE("exchange " + std::to_string(exchange) + ", killed at point " +
                   std::to_string(n) + " " + points[n]);
      fs::remove_all(target);
      WriteUnit(target, "old");
      ASSERT_EQ(testing::RunInChildKilledAt(n, [&] { return ReplaceUnit(target); }), "killed");
      const bool missing = !fs::exists(target);
      EXPECT_TRUE(missing ? !exchange : true) << "no unit at the target";
      std::vector<std::string> actions;
      std::string error;
      ASSERT_TRUE(CleanLeftovers(target, "id.txt", &actions, &error)) << error;
      const std::string version = ReadAll(target + "/id.txt");
      EXPECT_TRUE(version == "old" || version == "new") << version;
      EXPECT_EQ(ReadAll(target + "/sub/data.txt"), version + " data");
      EXPECT_FALSE(fs::exists(target + "/" + kTemporaryMarker));
      EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"unit"}));
      seen.insert(version);
    }
    EXPECT_EQ(seen, std::set<std::string>({"old", "new"}));
  }
  DisableExchangeForTesting(false);
}

TEST(StagedDirectoryTest, CleanupRemovesOnlyRecognizedLeftoversOfGoneProcesses) {
  testing::TempDir dir;
  const std::string target = dir.File("unit");
  WriteUnit(target, "current");
  const std::string dead = std::to_string(testing::DeadPid());
  // Recognized: the marker, the identity file, or nothing inside.
  fs::create_directories(target + ".aqs-tmp" + dead + "/sub");
  std::ofstream(target + ".aqs-tmp" + dead + "/" + kTemporaryMarker);
  WriteUnit(target + ".aqs-old" + dead, "older");
  const long dead2 = testing::DeadPid();
  fs::create_directories(target + ".aqs-tmp" + std::to_string(dead2));
  // Not recognized: a user's folder under such a name; and a live process's staging.
  const long dead3 = testing::DeadPid();
  fs::create_directories(target + ".aqs-tmp" + std::to_string(dead3));
  std::ofstream(target + ".aqs-tmp" + std::to_string(dead3) + "/notes.txt") << "mine";
  const std::string live = target + ".aqs-tmp" + std::to_string(static_cast<long>(getppid()));
  fs::create_directories(live);
  // Other names are never looked at.
  fs::create_directories(target + ".backup");
  fs::create_directories(target + ".aqs-tmpX1");
  std::vector<std::string> actions;
  std::string error;
  ASSERT_TRUE(CleanLeftovers(target, "id.txt", &actions, &error)) << error;
  EXPECT_EQ(Entries(dir.path()),
            std::set<std::string>({"unit", "unit.aqs-tmp" + std::to_string(dead3),
                                   fs::path(live).filename().string(), "unit.backup",
                                   "unit.aqs-tmpX1"}));
  EXPECT_EQ(ReadAll(target + "/id.txt"), "current");
  EXPECT_EQ(ReadAll(target + ".aqs-tmp" + std::to_string(dead3) + "/notes.txt"), "mine");
  ASSERT_EQ(actions.size(), 5u);
  int kept = 0;
  for (const std::string& action : actions) kept += action.rfind("kept ", 0) == 0;
  EXPECT_EQ(kept, 2);
  EXPECT_NE(std::find(actions.begin(), actions.end(),
                      "kept " + live + ": named like a temporary of process " +
                          std::to_string(static_cast<long>(getppid())) +
                          ", which is running but does not hold the lock; remove it yourself "
                          "if it is not needed"),
            actions.end());
}

// A missing target's moved-aside copy named with the pid of a running process (under
// the lock not its writer: the pid was reused) is recovered too; it was skipped as a
// live writer's, and the model it held was left beside a new one.
TEST(StagedDirectoryTest, AMovedAsideCopyIsRecoveredWhenItsPidWasReused) {
  testing::TempDir dir;
  const std::string target = dir.File("unit");
  const std::string running = std::to_string(static_cast<long>(getppid()));
  WriteUnit(target + ".aqs-old" + running, "old");
  std::vector<std::string> actions;
  std::string error;
  ASSERT_TRUE(CleanLeftovers(target, "id.txt", &actions, &error)) << error;
  EXPECT_EQ(ReadAll(target + "/id.txt"), "old");
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"unit"}));
  ASSERT_EQ(actions.size(), 1u);
  EXPECT_NE(actions[0].find("; its pid is now another process's)"), std::string::npos)
      << actions[0];
}

TEST(StagedDirectoryTest, MissingTargetIsRecoveredFromAMovedAsideCopy) {
  testing::TempDir dir;
  const std::string target = dir.File("unit");
  const std::string dead = std::to_string(testing::DeadPid());
  WriteUnit(target + ".aqs-old" + dead, "old");
  WriteUnit(target + ".aqs-tmp" + dead, "new");  // complete, but never put in place
  std::vector<std::string> actions;
  std::string error;
  ASSERT_TRUE(CleanLeftovers(target, "id.txt", &actions, &error)) << error;
  EXPECT_EQ(ReadAll(target + "/id.txt"), "old");
  EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"unit"}));
}

TEST(StagedDirectoryTest, RemovalKilledMidwayLeavesARecognizedLeftover) {
  testing::TempDir dir;
  const std::string target = dir.File("unit");
  WriteUnit(target, "current");
  const std::string displaced = target + ".aqs-tmp" + std::to_string(testing::DeadPid());
  const auto remove = [&] {
    std::string error;
    return RemoveTemporaryTree(displaced, &error);
  };
  WriteUnit(displaced, "x");
  fs::remove(displaced + "/id.txt");  // even without its identity file
  const std::vector<std::string> points = testing::FaultPointsOf([&] { remove(); });
  ASSERT_GE(points.size(), 3u);
  for (int n = 0; n < static_cast<int>(points.size()); ++n) {
    WriteUnit(displaced, "x");
    fs::remove(displaced + "/id.txt");
    ASSERT_EQ(testing::RunInChildKilledAt(n, remove), "killed");
    std::vector<std::string> actions;
    std::string error;
    ASSERT_TRUE(CleanLeftovers(target, "id.txt", &actions, &error)) << error;
    EXPECT_EQ(Entries(dir.path()), std::set<std::string>({"unit"})) << points[n];
  }
}

TEST(StagedDirectoryTest, KilledAtomicFileWriteLeavesOldOrNew) {
  testing::TempDir dir;
  const std::string path = dir.Write("out.txt", "old");
  const auto write = [&] {
    std::string error;
    return WriteFileAtomically(path, "new", &error);
  };
  const std::vector<std::string> points = testing::FaultPointsOf([&] { write(); });
  ASSERT_EQ(points, std::vector<std::string>({"atomic_file:written", "atomic_file:renamed"}));
  dir.Write("out.txt", "old");
  ASSERT_EQ(testing::RunInChildKilledAt(0, write), "killed");
  EXPECT_EQ(ReadAll(path), "old");
  ASSERT_EQ(testing::RunInChildKilledAt(1, write), "killed");
  EXPECT_EQ(ReadAll(path), "new");
}

}  // namespace
}  // namespace aqs
