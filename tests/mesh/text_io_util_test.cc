#include "mesh/text_io_util.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "testing/temp_dir.h"

namespace aqs {
namespace mesh_internal {
namespace {

TEST(TextIoUtilTest, TokenStreamCrossesLinesAndTracksThem) {
  testing::TempDir dir;
  const std::string path = dir.Write("t.txt", "a b\n# comment\n\nc\n  d e  \n");
  LineReader reader(path);
  TokenStream tokens(&reader, '#');
  std::vector<std::pair<std::string, int>> seen;
  while (const std::string* token = tokens.Next()) seen.push_back({*token, reader.line_number()});
  EXPECT_EQ(seen, (std::vector<std::pair<std::string, int>>{
                      {"a", 1}, {"b", 1}, {"c", 4}, {"d", 5}, {"e", 5}}));
  EXPECT_EQ(tokens.Where("end"), path + ":5: end");
}

TEST(TextIoUtilTest, QuotedAndInt) {
  EXPECT_EQ(Quoted("abc"), "'abc'");
  EXPECT_EQ(Quoted(std::string("a\0b", 3)), "'a\\x00b'");
  EXPECT_EQ(Quoted(std::string(50, 'x')), "'" + std::string(40, 'x') + "...'");
  std::string out = "n=";
  AppendInt(-1234567890123LL, &out);
  EXPECT_EQ(out, "n=-1234567890123");
}

TEST(TextIoUtilTest, CheckRecordCount) {
  testing::TempDir dir;
  const std::string path = dir.Write("c.txt", "header\n");
  LineReader reader(path);
  ASSERT_TRUE(reader.NextLine());
  std::string error;
  EXPECT_TRUE(CheckRecordCount(reader, 0, 4, 7, "points", &error));
  EXPECT_TRUE(CheckRecordCount(reader, 100, 4, 800, "points", &error));
  EXPECT_FALSE(CheckRecordCount(reader, 101, 4, 800, "points", &error));
  EXPECT_EQ(error, path +
                       ":1: the number of points (101) is larger than the file (800 bytes) "
                       "can hold: the file is truncated or the count is wrong");
  EXPECT_FALSE(CheckRecordCount(reader, -1, 4, 800, "points", &error));
  EXPECT_FALSE(CheckRecordCount(reader, 1LL << 40, 1, -1, "points", &error));
  EXPECT_TRUE(CheckRecordCount(reader, 1000, 1, -1, "points", &error));
}

}  // namespace
}  // namespace mesh_internal
}  // namespace aqs
