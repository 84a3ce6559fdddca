#include "util/atomic_file.h"

#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/file_contents.h"
#include "testing/temp_dir.h"
#include "util/staged_directory.h"

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

// ReadWholeFile reads regular files only: a FIFO in a key's place blocked the reader
// forever, and a link to /dev/zero was read until memory ran out.
TEST(AtomicFileTest, ReadWholeFileReadsOnlyRegularFiles) {
  testing::TempDir dir;
  EXPECT_EQ(ReadWholeFile(dir.Write("key.txt", "key\n")), "key\n");
  EXPECT_EQ(ReadWholeFile(dir.File("missing.txt")), "");
  const std::string fifo = dir.File("fifo.txt");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_EQ(ReadWholeFile(fifo), "");  // returns at once
  const std::string zero = dir.File("zero.txt");
  std::filesystem::create_symlink("/dev/zero", zero);
  EXPECT_EQ(ReadWholeFile(zero), "");
  EXPECT_EQ(ReadWholeFile(dir.path()), "");  // a folder
}

TEST(AtomicFileTest, UnwritableDirectoryIsAnError) {
  std::string error;
  EXPECT_FALSE(WriteFileAtomically("/nonexistent/dir/x.txt", "a", &error));
  EXPECT_NE(error.find("/nonexistent/dir/x.txt"), std::string::npos);
}

// A killed writer's temporary files are removed where their process is gone (999999999
// is above any pid) and their name is one of the folder's outputs; a live process's
// (pid 1), other files' and names that only look alike are kept.
TEST(AtomicFileTest, StaleTemporaryFilesOfOutputsAreRemoved) {
  testing::TempDir dir;
  const std::string dead = dir.Write("frames.csv.tmp999999999", "half");
  const std::string mine = dir.Write("f1.obj.tmp" + std::to_string(::getpid()), "half");
  const std::string live = dir.Write("f2.obj.tmp1", "someone's");
  const std::string other = dir.Write("notes.txt.tmp999999999", "the user's");
  const std::string not_pid = dir.Write("frames.csv.tmpx1", "not a temporary file");
  const std::string output = dir.Write("frames.csv", "done");
  std::filesystem::create_directories(dir.File("sub"));
  const std::string nested = dir.Write("sub/frames.csv.tmp999999999", "not this folder's");
  std::vector<std::string> removed;
  std::string error;
  auto is_output = [](const std::string& name) {
    return name == "frames.csv" || name == "f1.obj" || name == "f2.obj";
  };
  ASSERT_TRUE(RemoveStaleTemporaryFiles(dir.path(), is_output, &removed, &error)) << error;
  EXPECT_FALSE(std::filesystem::exists(dead));
  EXPECT_FALSE(std::filesystem::exists(mine));
  for (const std::string& kept : {live, other, not_pid, output, nested}) {
    EXPECT_TRUE(std::filesystem::exists(kept)) << kept;
  }
  ASSERT_EQ(removed.size(), 3u);
  std::sort(removed.begin(), removed.end());
  EXPECT_EQ(removed[0], "kept " + live + ": named like a temporary file of process 1, which "
                        "runs; remove it if no ActiveQS process writes into " + dir.path());
  EXPECT_EQ(removed[2], "removed " + dead + ", left by process 999999999");
  // A folder that cannot be listed is left as it is.
  EXPECT_TRUE(RemoveStaleTemporaryFiles(dir.File("none"), is_output, &removed, &error));
}

// A temporary file named after a process that started after the file was last written
// cannot be that process's (its pid was reused, as after a reboot): it is removed. One
// written after the process started is kept, and said so (it used to be kept silently,
// and later model saves refused the folder for it).
TEST(AtomicFileTest, TemporaryFilesOfAReusedPidAreRemoved) {
  const pid_t child = ::fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    ::pause();
    ::_exit(0);
  }
  testing::TempDir dir;
  const std::string suffix = ".tmp" + std::to_string(child);
  const std::string older = dir.Write("a.obj" + suffix, "a dead writer's");
  const std::string newer = dir.Write("b.obj" + suffix, "maybe the child's");
  std::filesystem::last_write_time(
      older, std::filesystem::last_write_time(older) - std::chrono::hours(1));
  EXPECT_TRUE(ProcessStartedAfterWrite(child, older));
  EXPECT_FALSE(ProcessStartedAfterWrite(child, newer));
  EXPECT_FALSE(ProcessStartedAfterWrite(999999999, older));
  std::vector<std::string> actions;
  std::string error;
  const bool ok = RemoveStaleTemporaryFiles(
      dir.path(), [](const std::string& name) { return name == "a.obj" || name == "b.obj"; },
      &actions, &error);
  ::kill(child, SIGKILL);
  ::waitpid(child, nullptr, 0);
  ASSERT_TRUE(ok) << error;
  EXPECT_FALSE(std::filesystem::exists(older));
  EXPECT_TRUE(std::filesystem::exists(newer));
  std::sort(actions.begin(), actions.end());
  ASSERT_EQ(actions.size(), 2u);
  EXPECT_EQ(actions[0].rfind("kept " + newer + ": ", 0), 0u) << actions[0];
  EXPECT_EQ(actions[1], "removed " + older + ", left by process " + std::to_string(child) +
                            " (its pid now names a process started after it was written)");
}

}  // namespace
}  // namespace aqs
