// Input files are regular files read with bounded lines; outputs are checked before the
// work; options checks name their fields; memory estimates name the limit.

#include "util/input_file.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "testing/temp_dir.h"
#include "util/line_reader.h"
#include "util/matrix_io.h"
#include "util/memory_limit.h"
#include "util/option_checks.h"

namespace aqs {
namespace {

bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(InputFileTest, OnlyRegularFilesAreRead) {
  testing::TempDir dir;
  const std::string regular = dir.Write("a.txt", "1 2 3\n");
  std::string error;
  EXPECT_TRUE(CheckInputFile(regular, &error)) << error;
  // A symbolic link to a regular file is fine.
  const std::string link = dir.File("link.txt");
  ASSERT_EQ(::symlink(regular.c_str(), link.c_str()), 0);
  EXPECT_TRUE(CheckInputFile(link, &error)) << error;

  EXPECT_FALSE(CheckInputFile(dir.path(), &error));
  EXPECT_TRUE(Contains(error, "is a directory")) << error;

  const std::string fifo = dir.File("pipe.mesh");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_FALSE(CheckInputFile(fifo, &error));
  EXPECT_TRUE(Contains(error, "FIFO")) << error;
  // The line reader refuses it before opening it (opening a FIFO would block).
  LineReader fifo_reader(fifo);
  EXPECT_FALSE(fifo_reader.ok());
  EXPECT_TRUE(Contains(fifo_reader.error(), fifo)) << fifo_reader.error();

  // A mesh that is a symbolic link to /dev/zero never ends: refused.
  const std::string zero = dir.File("zero.msh");
  ASSERT_EQ(::symlink("/dev/zero", zero.c_str()), 0);
  EXPECT_FALSE(CheckInputFile(zero, &error));
  EXPECT_TRUE(Contains(error, "character device")) << error;
  Eigen::MatrixXd matrix;
  EXPECT_FALSE(ReadMatrixFile(zero, -1, -1, &matrix, &error));
  EXPECT_TRUE(Contains(error, "character device")) << error;

  EXPECT_FALSE(CheckInputFile(dir.File("missing.txt"), &error));
  EXPECT_TRUE(Contains(error, "missing.txt")) << error;
}

TEST(InputFileTest, OutputPathsAreCheckedBeforeTheWork) {
  testing::TempDir dir;
  std::string error;
  EXPECT_TRUE(CheckOutputFile(dir.File("out.obj"), &error)) << error;
  EXPECT_TRUE(CheckOutputFile("relative_name.obj", &error)) << error;
  EXPECT_FALSE(CheckOutputFile(dir.File("missing/out.obj"), &error));
  EXPECT_TRUE(Contains(error, "does not exist")) << error;
  EXPECT_TRUE(Contains(error, dir.File("missing"))) << error;
  const std::string file = dir.Write("plain.txt", "x");
  EXPECT_FALSE(CheckOutputFile(file + "/out.obj", &error));
  EXPECT_TRUE(Contains(error, "not a folder")) << error;
  std::filesystem::create_directories(dir.File("sub"));
  EXPECT_FALSE(CheckOutputFile(dir.File("sub"), &error));
  EXPECT_TRUE(Contains(error, "is a directory")) << error;
  if (::geteuid() != 0) {  // root writes anywhere
    std::filesystem::create_directories(dir.File("locked"));
    ::chmod(dir.File("locked").c_str(), 0500);
    EXPECT_FALSE(CheckOutputFile(dir.File("locked/out.obj"), &error));
    EXPECT_TRUE(Contains(error, "not writable")) << error;
    ::chmod(dir.File("locked").c_str(), 0700);
  }
}

TEST(LineReaderLimitsTest, LongLineStopsTheReaderWithAnError) {
  testing::TempDir dir;
  // A one-line file longer than the limit: refused after reading the limit, not whole.
  std::string line(static_cast<size_t>(kMaxLineBytes) + 10, '1');
  for (size_t i = 1; i < line.size(); i += 2) line[i] = ' ';
  const std::string path = dir.Write("long.txt", "0 1 2\n" + line + "\n3 4 5\n");
  LineReader reader(path);
  ASSERT_TRUE(reader.ok());
  std::vector<std::string> tokens;
  ASSERT_TRUE(reader.NextTokens(&tokens));
  EXPECT_EQ(tokens.size(), 3u);
  EXPECT_FALSE(reader.NextTokens(&tokens));
  EXPECT_FALSE(reader.ok());
  EXPECT_EQ(reader.error().find(path + ":2: the line is longer than"), 0u) << reader.error();
  EXPECT_FALSE(reader.NextTokens(&tokens)) << "stays failed";

  // A line of exactly the limit is fine, and so is a last line without a newline.
  const std::string exact = dir.Write("exact.txt", std::string(kMaxLineBytes, 'x') + "\nend");
  LineReader exact_reader(exact);
  ASSERT_TRUE(exact_reader.NextLine());
  EXPECT_EQ(exact_reader.line().size(), static_cast<size_t>(kMaxLineBytes));
  ASSERT_TRUE(exact_reader.NextLine());
  EXPECT_EQ(exact_reader.line(), "end");
  EXPECT_FALSE(exact_reader.NextLine());
  EXPECT_TRUE(exact_reader.ok());
}

TEST(LineReaderLimitsTest, NumbersAreDecimalOnly) {
  double d = 0;
  long long i = 0;
  for (const char* ok : {"0", "-1.5", "+2.", ".5", "1e3", "1E-3", "-0.0", "007"}) {
    EXPECT_TRUE(ParseDouble(ok, &d)) << ok;
  }
  for (const char* bad : {"0x10", "0X1p3", "nan", "-inf", "infinity", "1e", "e5", ".", "+",
                          "1.5.2", " 1", "1 ", "1e+", "--1", "1d0"}) {
    EXPECT_FALSE(ParseDouble(bad, &d)) << bad;
  }
  EXPECT_TRUE(ParseInt64("-42", &i));
  EXPECT_EQ(i, -42);
  for (const char* bad : {"0x10", " 1", "1 ", "+", "-", "1e3", "12a"}) {
    EXPECT_FALSE(ParseInt64(bad, &i)) << bad;
  }
}

TEST(OptionChecksTest, FirstFailureNamesTheField) {
  std::string error;
  EXPECT_TRUE(OptionChecks().Positive("a", 1.0).IntInRange("b", 3, 0, 5).Done(&error));
  EXPECT_TRUE(error.empty());
  EXPECT_FALSE(OptionChecks()
                   .Positive("a", 1.0)
                   .NonNegative("b", std::nan(""))
                   .Positive("c", -1.0)
                   .Done(&error));
  EXPECT_EQ(error, "b must be finite and >= 0 (is nan)");
  EXPECT_FALSE(OptionChecks().Positive("t", std::numeric_limits<double>::infinity()).Done(&error));
  EXPECT_EQ(error, "t must be finite and > 0 (is inf)");
  EXPECT_FALSE(OptionChecks().Nested("solver", false, "num_threads must be >= 1 (is 0)").Done(&error));
  EXPECT_EQ(error, "solver.num_threads must be >= 1 (is 0)");
  EXPECT_FALSE(OptionChecks().IntInRange("steps", 100000, 0, 256).Done(&error));
  EXPECT_EQ(error, "steps must be in [0, 256] (is 100000)");
}

TEST(MemoryLimitTest, EstimatesAboveTheLimitAreRefusedWithBoth) {
  std::string error;
  EXPECT_TRUE(CheckMemoryEstimate(1e9, 8e9, "x", "", &error));
  EXPECT_FALSE(CheckMemoryEstimate(12.3e9, 8e9, "meshing", "a lattice of 1e9 elements", &error));
  EXPECT_EQ(error, "max_memory_bytes (8 GB) is below the estimated 12.3 GB that meshing needs "
                   "(a lattice of 1e9 elements); raise the limit to proceed");
  EXPECT_FALSE(CheckMemoryEstimate(std::nan(""), 8e9, "x", "", &error));
  EXPECT_EQ(FormatBytes(812e6), "812 MB");
  EXPECT_EQ(FormatBytes(1.02e12), "1.02 TB");
}

}  // namespace
}  // namespace aqs
