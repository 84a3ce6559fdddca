#include "util/vertex_ranges.h"

#include <gtest/gtest.h>

namespace aqs {
namespace {

std::vector<int> Parse(const std::string& text) {
  std::vector<int> vertices;
  std::string error;
  EXPECT_TRUE(ParseVertexRanges(text, &vertices, &error)) << text << ": " << error;
  return vertices;
}

std::string ParseError(const std::string& text) {
  std::vector<int> vertices = {42};
  std::string error;
  EXPECT_FALSE(ParseVertexRanges(text, &vertices, &error)) << text;
  EXPECT_EQ(vertices, std::vector<int>({42})) << "unchanged on failure: " << text;
  return error;
}

TEST(VertexRangesTest, ParsesHalfOpenClosedAndSingleItemsInOrder) {
  EXPECT_EQ(Parse("2:5"), std::vector<int>({2, 3, 4}));
  EXPECT_EQ(Parse("2-5"), std::vector<int>({2, 3, 4, 5}));
  EXPECT_EQ(Parse("7"), std::vector<int>({7}));
  EXPECT_EQ(Parse("9,0:2,,4-4,3"), std::vector<int>({9, 0, 1, 4, 3}));
  EXPECT_EQ(Parse(""), std::vector<int>());
}

TEST(VertexRangesTest, BadItemsAreNamed) {
  EXPECT_EQ(ParseError("0:2,5:3"), "vertex range '5:3': expected a:b with a < b (a:a is empty)");
  EXPECT_EQ(ParseError("1:x"), "vertex range '1:x': expected a:b with a < b (a:a is empty)");
  // Lists of no vertex: callers read an empty list as "all vertices".
  EXPECT_EQ(ParseError("3:3"), "vertex range '3:3': expected a:b with a < b (a:a is empty)");
  EXPECT_EQ(ParseError(",,"), "vertex ranges ',,': no vertex listed");
  EXPECT_EQ(ParseError("4-2"), "vertex range '4-2': expected a-b with a <= b");
  EXPECT_EQ(ParseError("3-"), "vertex range '3-': expected a-b with a <= b");
  EXPECT_EQ(ParseError("abc"), "vertex range 'abc': not an index");
  EXPECT_EQ(ParseError(" 1"), "vertex range ' 1': not an index");
  EXPECT_EQ(ParseError("-3"), "vertex range '-3': negative index");
  EXPECT_EQ(ParseError("-3:2"), "vertex range '-3:2': negative index");
  // Sizes no mesh has are refused before anything is allocated (2e9 indices were 8 GB),
  // and INT_MAX does not overflow.
  const std::string beyond = "vertices, more than any mesh has";
  EXPECT_NE(ParseError("0:2000000000").find(beyond), std::string::npos);
  EXPECT_NE(ParseError("0-2147483647").find(beyond), std::string::npos);
  EXPECT_NE(ParseError("2147483647").find(beyond), std::string::npos);
  EXPECT_NE(ParseError("0-50000000").find(beyond), std::string::npos);
  EXPECT_NE(ParseError("0:30000000,0:30000000").find(beyond), std::string::npos);
  std::vector<int> vertices;
  std::string error;
  // Overlaps: a vertex listed twice would count twice in every mean.
  EXPECT_EQ(ParseError("0:3,1:2"), "vertex ranges '0:3,1:2': vertex 1 is listed twice ('0:3' "
                                   "and '1:2')");
  EXPECT_EQ(ParseError("7,2-4,,9,4"), "vertex ranges '7,2-4,,9,4': vertex 4 is listed twice "
                                      "('2-4' and '4')");
  EXPECT_EQ(ParseError("5,5"), "vertex ranges '5,5': vertex 5 is listed twice ('5' and '5')");
  // The smallest vertex listed twice, its items in the order given.
  EXPECT_EQ(ParseError("3:5,0:4"), "vertex ranges '3:5,0:4': vertex 3 is listed twice ('3:5' "
                                   "and '0:4')");
  EXPECT_EQ(ParseError("12:13,0:10,11:12,9:20"),
            "vertex ranges '12:13,0:10,11:12,9:20': vertex 9 is listed twice ('0:10' and "
            "'9:20')");
  EXPECT_TRUE(ParseVertexRanges("20:30,0:10,10:20,30", &vertices, &error)) << error;
  EXPECT_EQ(vertices.size(), 31u);
  EXPECT_TRUE(ParseVertexRanges("49999999", &vertices, &error)) << error;
}

TEST(VertexRangesTest, FormatIsTheInverse) {
  EXPECT_EQ(FormatVertexRanges({0, 1, 2, 5, 7, 8}), "0:3,5:6,7:9");
  EXPECT_EQ(FormatVertexRanges({4, 3}), "4:5,3:4");
  EXPECT_EQ(FormatVertexRanges({}), "");
  EXPECT_EQ(Parse(FormatVertexRanges({0, 1, 2, 5, 7, 8})), std::vector<int>({0, 1, 2, 5, 7, 8}));
  EXPECT_EQ(Parse(FormatVertexRanges({4, 3, 9})), std::vector<int>({4, 3, 9}));
}

}  // namespace
}  // namespace aqs
