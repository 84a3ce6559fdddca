// CSV logs of iterative work (util/iteration_log.h): what a resumed run keeps of them,
// and appends that say when they fail.

#include "util/iteration_log.h"

#include <sys/stat.h>

#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "testing/file_contents.h"
#include "testing/temp_dir.h"

namespace aqs {
namespace {

constexpr char kHeader[] = "iteration,loss,seconds\n";

TEST(IterationLogTest, WholeRowsHaveTheHeadersFieldsAllNumbers) {
  EXPECT_TRUE(IsWholeLogRow("3,0.5,1e-3", kHeader));
  EXPECT_FALSE(IsWholeLogRow("3,0.5", kHeader));        // cut while appended
  EXPECT_FALSE(IsWholeLogRow("3,0.5,1e-3,7", kHeader));  // another layout
  EXPECT_FALSE(IsWholeLogRow("3,nan,1", kHeader));
  EXPECT_FALSE(IsWholeLogRow("3,0.5,1.2.3", kHeader));
}

// A killed run logged rows past its checkpoint, a partial row, a row twice and rows out
// of order: the resume keeps rows 0..checkpoint in order, once each.
TEST(IterationLogTest, AResumeKeepsTheWholeRowsUpToItsCheckpointInOrder) {
  testing::TempDir dir;
  const std::string path =
      dir.Write("log.csv", std::string(kHeader) +
                               "0,1,0\n1,0.9,1\n2,0.8,2\n1,0.85,3\n3,0.7,4\n4,0.6,5\n5,0.5");
  int last = -2;
  std::string error;
  std::string last_line = "stale";
  ASSERT_TRUE(PrepareIterationLog(path, kHeader, 3, &last, &error, &last_line)) << error;
  EXPECT_EQ(last, 3);
  EXPECT_EQ(last_line, "3,0.7,4");
  EXPECT_EQ(testing::ReadAll(path), std::string(kHeader) + "0,1,0\n1,0.9,1\n2,0.8,2\n3,0.7,4\n");
  // A fresh run (iteration 0) keeps the header alone; a missing log becomes one.
  ASSERT_TRUE(PrepareIterationLog(path, kHeader, 0, &last, &error, &last_line)) << error;
  EXPECT_EQ(last, -1);
  EXPECT_EQ(last_line, "");
  EXPECT_EQ(testing::ReadAll(path), kHeader);
  const std::string missing = dir.File("new.csv");
  ASSERT_TRUE(PrepareIterationLog(missing, kHeader, 7, &last, &error)) << error;
  EXPECT_EQ(last, -1);
  EXPECT_EQ(testing::ReadAll(missing), kHeader);
  // Something other than a regular file in the log's place is refused, not read (a FIFO
  // blocked a resumed training forever).
  const std::string fifo = dir.File("fifo.csv");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_FALSE(PrepareIterationLog(fifo, kHeader, 3, &last, &error));
  EXPECT_EQ(error, fifo + " is not a regular file: remove it (the log is written anew)");
}

TEST(IterationLogTest, AppendsAndSaysWhyNot) {
  testing::TempDir dir;
  const std::string path = dir.Write("log.csv", kHeader);
  std::string error;
  ASSERT_TRUE(AppendLogRow(path, "0,1,0\n", &error)) << error;
  ASSERT_TRUE(AppendLogRow(path, "1,0.5,2\n", &error)) << error;
  EXPECT_EQ(testing::ReadAll(path), std::string(kHeader) + "0,1,0\n1,0.5,2\n");
  const std::string gone = dir.File("removed/log.csv");
  EXPECT_FALSE(AppendLogRow(gone, "2,0.25,3\n", &error));
  EXPECT_EQ(error, gone + ": cannot append to the log (No such file or directory)");
  // A full disk (where the machine has the device that acts as one).
  std::error_code code;
  if (std::filesystem::exists("/dev/full", code)) {
    EXPECT_FALSE(AppendLogRow("/dev/full", "2,0.25,3\n", &error));
    EXPECT_EQ(error, "/dev/full: cannot append to the log (No space left on device)");
  }
}

// A row appended after part of a row (an append that failed when the disk was full, or
// a kill) replaces the part. It used to be glued to the part (both lost as one malformed
// line), then put on a line of its own, which kept a part cut in its last field as a
// whole row with a wrong number.
TEST(IterationLogTest, ARowAfterAPartialRowReplacesThePart) {
  testing::TempDir dir;
  for (const char* part : {"1,0.", "1,0.4,12.", "1,0.4,1e-0", "1,0.4,1"}) {
    const std::string path =
        dir.Write("log.csv", std::string(kHeader) + "0,1,0\n" + part);
    std::string error;
    ASSERT_TRUE(AppendLogRow(path, "2,0.25,3\n", &error)) << error;
    EXPECT_EQ(testing::ReadAll(path), std::string(kHeader) + "0,1,0\n2,0.25,3\n") << part;
    int last_row = -1;
    ASSERT_TRUE(PrepareIterationLog(path, kHeader, 2, &last_row, &error)) << error;
    EXPECT_EQ(last_row, 2) << part;
    EXPECT_EQ(testing::ReadAll(path), std::string(kHeader) + "0,1,0\n2,0.25,3\n") << part;
  }
  // A part longer than the blocks the end is searched in.
  {
    const std::string path = dir.Write(
        "long.csv", std::string(kHeader) + "0,1,0\n1,0.4," + std::string(9000, '1'));
    std::string error;
    ASSERT_TRUE(AppendLogRow(path, "2,0.25,3\n", &error)) << error;
    EXPECT_EQ(testing::ReadAll(path), std::string(kHeader) + "0,1,0\n2,0.25,3\n");
  }
  // Text without a newline is not a log this code wrote: it stays, and the row follows
  // on a line of its own.
  const std::string path = dir.Write("other.csv", "iteration");
  std::string error;
  ASSERT_TRUE(AppendLogRow(path, "2,0.25,3\n", &error)) << error;
  EXPECT_EQ(testing::ReadAll(path), "iteration\n2,0.25,3\n");
}

}  // namespace
}  // namespace aqs
