#include "util/matrix_io.h"

#include <fstream>

#include <gtest/gtest.h>

#include "testing/temp_dir.h"

namespace aqs {
namespace {

TEST(MatrixIoTest, RoundTripAndChecks) {
  testing::TempDir dir;
  const Eigen::MatrixXd m = Eigen::MatrixXd::Random(3, 7);
  std::string error;
  ASSERT_TRUE(WriteMatrixFile(dir.File("m.bin"), m, &error)) << error;
  Eigen::MatrixXd back;
  ASSERT_TRUE(ReadMatrixFile(dir.File("m.bin"), 3, 7, &back, &error)) << error;
  EXPECT_EQ(back, m);
  ASSERT_TRUE(ReadMatrixFile(dir.File("m.bin"), -1, -1, &back, &error)) << error;
  EXPECT_FALSE(ReadMatrixFile(dir.File("m.bin"), 6, 7, &back, &error));
  EXPECT_NE(error.find("a 3 x 7 matrix where 6 x 7 was expected"), std::string::npos) << error;
  // Truncated file.
  std::ofstream(dir.File("short.bin"), std::ios::binary).write("AQSMAT1\n", 8);
  EXPECT_FALSE(ReadMatrixFile(dir.File("short.bin"), -1, -1, &back, &error));
  EXPECT_NE(error.find("short.bin"), std::string::npos);
  dir.Write("text.bin", "hello world, this is not a matrix at all");
  EXPECT_FALSE(ReadMatrixFile(dir.File("text.bin"), -1, -1, &back, &error));
  EXPECT_NE(error.find("bad header"), std::string::npos);
  EXPECT_FALSE(ReadMatrixFile(dir.File("missing.bin"), -1, -1, &back, &error));
}

}  // namespace
}  // namespace aqs
