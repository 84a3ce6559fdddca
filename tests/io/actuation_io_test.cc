#include "io/actuation_io.h"

#include <fstream>
#include <limits>
#include <string>

#include <gtest/gtest.h>

#include "testing/temp_dir.h"

namespace aqs {
namespace {

TEST(ActuationIoTest, RoundTripsBitForBit) {
  testing::TempDir dir;
  ActuationMatrix a(6, 3);
  a << 1.0 / 3, 2, 3, 0.1, 0.2, 0.3,
       4, 5, 6, -1e-300, 7e200, 8,
       9, 10, 11, 12, 13, 1e-17;
  std::string error;
  ASSERT_TRUE(WriteActuation(dir.File("a.txt"), a, "line one\nline two", &error)) << error;
  ActuationMatrix back;
  ASSERT_TRUE(ReadActuation(dir.File("a.txt"), 3, &back, &error)) << error;
  EXPECT_EQ((back - a).cwiseAbs().maxCoeff(), 0.0);
}

// A non-finite number is refused naming the element, and nothing is written (the reader
// refuses nan and inf).
TEST(ActuationIoTest, NonFiniteNumbersAreRefusedNamingTheElement) {
  testing::TempDir dir;
  ActuationMatrix a = IdentityActuations(4);
  a(5, 3) = -std::numeric_limits<double>::infinity();
  std::string error;
  EXPECT_FALSE(WriteActuation(dir.File("a.txt"), a, "", &error));
  EXPECT_NE(error.find("a.txt: element 3 has a number that is not finite (-inf)"),
            std::string::npos) << error;
  EXPECT_FALSE(std::ifstream(dir.File("a.txt")).good());
}

// A damaged file's long token is shortened in the message and its control bytes escaped
// (the whole 100 kB token was echoed before 2026-12-07).
TEST(ActuationIoTest, LongBadTokensAreShortenedInTheMessage) {
  testing::TempDir dir;
  std::string token(100000, 'x');
  token[3] = '\x01';
  dir.Write("a.txt", "1 1 1 0 0 0\n1 1 " + token + " 0 0 0\n");
  ActuationMatrix a;
  std::string error;
  EXPECT_FALSE(ReadActuation(dir.File("a.txt"), 2, &a, &error));
  EXPECT_LT(error.size(), 200u) << error.size();
  EXPECT_NE(error.find("a.txt:2"), std::string::npos) << error;
  EXPECT_NE(error.find("'xxx\\x01xx"), std::string::npos) << error;
}

TEST(ActuationIoTest, WrongCountsAndBadNumbersNameTheLine) {
  testing::TempDir dir;
  ActuationMatrix a;
  std::string error;
  const std::string two = dir.Write("two.txt", "# comment\n1 1 1 0 0 0\n\n1 1 1 0 0 0\n");
  EXPECT_FALSE(ReadActuation(two, 3, &a, &error));
  EXPECT_NE(error.find("2 sxx syy szz sxy sxz syz lines for a mesh of 3 elements"),
            std::string::npos) << error;
  EXPECT_FALSE(ReadActuation(two, 1, &a, &error));
  EXPECT_NE(error.find("two.txt:4: more lines than the mesh's 1 elements"), std::string::npos)
      << error;
  const std::string short_line = dir.Write("short.txt", "1 1 1 0 0\n");
  EXPECT_FALSE(ReadActuation(short_line, 1, &a, &error));
  EXPECT_NE(error.find("short.txt:1: expected 6 numbers"), std::string::npos) << error;
  const std::string bad = dir.Write("bad.txt", "1 1 1 0 0 x\n");
  EXPECT_FALSE(ReadActuation(bad, 1, &a, &error));
  EXPECT_NE(error.find("bad.txt:1: expected a finite number, got 'x'"), std::string::npos)
      << error;
  const std::string nan = dir.Write("nan.txt", "1 1 nan 0 0 0\n");
  EXPECT_FALSE(ReadActuation(nan, 1, &a, &error));
  EXPECT_FALSE(ReadActuation(dir.File("missing.txt"), 1, &a, &error));
  EXPECT_NE(error.find("missing.txt"), std::string::npos);
}

// Actuations that drive a simulation must be positive definite with stretches in
// [1e-3, 1e3]: S = -I and S = 1e-12 I are refused with a count and the first line.
TEST(ActuationIoTest, TargetsMustBePositiveDefinite) {
  testing::TempDir dir;
  ActuationMatrix a;
  std::string error;
  ASSERT_TRUE(ReadActuationTargets(
      dir.Write("ok.txt", "1 1 1 0 0 0\n0.5 2 1 0.3 0 0\n0.001 1000 1 0 0 0\n"), 3, &a, &error))
      << error;
  EXPECT_EQ(a(1, 2), 1000.0);
  const std::string inverted =
      dir.Write("inverted.txt", "1 1 1 0 0 0\n# S = -I\n-1 -1 -1 0 0 0\n-1 -1 -1 0 0 0\n");
  EXPECT_FALSE(ReadActuationTargets(inverted, 3, &a, &error));
  EXPECT_EQ(error.find(inverted + ":3: 2 of 3 actuations are not positive definite"), 0u) << error;
  EXPECT_NE(error.find("element 1, has eigenvalues -1, -1, -1"), std::string::npos) << error;
  const std::string tiny = dir.Write("tiny.txt", "1e-12 1e-12 1e-12 0 0 0\n");
  EXPECT_FALSE(ReadActuationTargets(tiny, 1, &a, &error));
  EXPECT_NE(error.find("tiny.txt:1: 1 of 1"), std::string::npos) << error;
  // Indefinite through its off-diagonal: eigenvalues -1 and 3.
  EXPECT_FALSE(ReadActuationTargets(dir.Write("shear.txt", "1 1 1 2 0 0\n"), 1, &a, &error));
  EXPECT_FALSE(ReadActuationTargets(dir.Write("huge.txt", "1e4 1 1 0 0 0\n"), 1, &a, &error));
  // Plain ReadActuation (gradients) takes any finite numbers.
  EXPECT_TRUE(ReadActuation(inverted, 3, &a, &error)) << error;
  int first = -2;
  EXPECT_EQ(CountNonPositiveDefinite(a, &first), 2);
  EXPECT_EQ(first, 1);
}

TEST(ActuationIoTest, PositiveScalars) {
  testing::TempDir dir;
  Eigen::VectorXd mu;
  std::string error;
  ASSERT_TRUE(ReadScalarsPerLine(dir.Write("mu.txt", "1\n2.5\n"), 2, true, &mu, &error));
  EXPECT_EQ(mu[1], 2.5);
  EXPECT_FALSE(ReadScalarsPerLine(dir.Write("neg.txt", "1\n-2\n"), 2, true, &mu, &error));
  EXPECT_NE(error.find("element 1 is -2"), std::string::npos) << error;
}

}  // namespace
}  // namespace aqs
