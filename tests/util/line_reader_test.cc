#include "util/line_reader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

#include "testing/temp_dir.h"
#include "util/number_format.h"

namespace aqs {
namespace {

TEST(LineReaderTest, TokensSkipCommentsAndBlankLinesAndCountLines) {
  testing::TempDir dir;
  const std::string path = dir.Write("a.txt", "# header\n\n1 2  3\r\n  # only comment\nx y # tail\n");
  LineReader reader(path);
  ASSERT_TRUE(reader.ok());
  std::vector<std::string> tokens;
  ASSERT_TRUE(reader.NextTokens(&tokens));
  EXPECT_EQ(reader.line_number(), 3);
  EXPECT_EQ(tokens, (std::vector<std::string>{"1", "2", "3"}));
  ASSERT_TRUE(reader.NextTokens(&tokens));
  EXPECT_EQ(reader.line_number(), 5);
  EXPECT_EQ(tokens, (std::vector<std::string>{"x", "y"}));
  EXPECT_EQ(reader.Where("bad"), path + ":5: bad");
  EXPECT_FALSE(reader.NextTokens(&tokens));
}

TEST(LineReaderTest, AByteOrderMarkIsNotPartOfTheFirstLine) {
  testing::TempDir dir;
  LineReader reader(dir.Write("bom.txt", "\xEF\xBB\xBFv 1 2 3\n\xEF\xBB\xBFv\n"));
  std::vector<std::string> tokens;
  ASSERT_TRUE(reader.NextTokens(&tokens));
  EXPECT_EQ(tokens, (std::vector<std::string>{"v", "1", "2", "3"}));
  ASSERT_TRUE(reader.NextTokens(&tokens));  // only the file's first line loses it
  EXPECT_EQ(tokens, (std::vector<std::string>{"\xEF\xBB\xBFv"}));
}

TEST(LineReaderTest, SplitTokensReusesStorageAndDropsComments) {
  std::vector<std::string> tokens = {"old", "tokens", "here", "and", "more"};
  SplitTokens("  a\tbb  ccc # d e", '#', &tokens);
  EXPECT_EQ(tokens, (std::vector<std::string>{"a", "bb", "ccc"}));
  SplitTokens("x#y", '\0', &tokens);
  EXPECT_EQ(tokens, (std::vector<std::string>{"x#y"}));
  SplitTokens("   ", '#', &tokens);
  EXPECT_TRUE(tokens.empty());
  // Without a comment character '#' is a token character.
  EXPECT_EQ(SplitTokens(" a\r\n\v\fb\t#c "), (std::vector<std::string>{"a", "b", "#c"}));
}

TEST(LineReaderTest, MissingFileNamesPath) {
  LineReader reader("/nonexistent/dir/file.txt");
  EXPECT_FALSE(reader.ok());
  EXPECT_NE(reader.error().find("/nonexistent/dir/file.txt"), std::string::npos);
}

TEST(LineReaderTest, StrictNumberParsing) {
  double d = 0;
  int i = 0;
  EXPECT_TRUE(ParseDouble("1.5e-3", &d));
  EXPECT_DOUBLE_EQ(d, 1.5e-3);
  EXPECT_FALSE(ParseDouble("1.5x", &d));
  EXPECT_FALSE(ParseDouble("nan", &d));
  EXPECT_FALSE(ParseDouble("inf", &d));
  EXPECT_FALSE(ParseDouble("", &d));
  EXPECT_FALSE(ParseDouble("1e400", &d));
  EXPECT_TRUE(ParseInt("-12", &i));
  EXPECT_EQ(i, -12);
  EXPECT_FALSE(ParseInt("12.0", &i));
  EXPECT_FALSE(ParseInt("99999999999", &i));
}

TEST(NumberFormatTest, RoundTripsExactly) {
  for (double v : {0.1, 1.0 / 3.0, -2.5e-300, 6.02214076e23, 1e-7 + 1e-23, 0.0, -0.0,
                   4.9406564584124654e-324, 1.7976931348623157e308, -1.0 / 7.0}) {
    double back = 0;
    ASSERT_TRUE(ParseDouble(FormatDouble(v), &back)) << FormatDouble(v);
    EXPECT_EQ(back, v);
    EXPECT_EQ(std::signbit(back), std::signbit(v));
  }
  // Random doubles over the whole exponent range, bit for bit.
  std::mt19937_64 random(7);
  for (int i = 0; i < 10000; ++i) {
    uint64_t bits = random();
    double v = 0;
    std::memcpy(&v, &bits, sizeof(v));
    if (!std::isfinite(v)) continue;
    double back = 0;
    ASSERT_TRUE(ParseDouble(FormatDouble(v), &back)) << FormatDouble(v);
    ASSERT_EQ(back, v) << FormatDouble(v);
  }
  // Shortest text: what a person reads in the files.
  EXPECT_EQ(FormatDouble(0.1), "0.1");
  EXPECT_EQ(FormatDouble(-2.0), "-2");
  EXPECT_EQ(FormatDouble(1e-7), "1e-07");
}

}  // namespace
}  // namespace aqs
