// ParseObstacleSpecs (contact/obstacle.h): the --obstacles text of aqs_collide and
// ReadMovingObstacles, "path [vertices=a:b] [bone=name]" items separated by commas.

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "contact/obstacle.h"

namespace aqs {
namespace {

std::vector<ObstacleSpec> Parse(const std::string& text) {
  std::vector<ObstacleSpec> specs;
  std::string error;
  EXPECT_TRUE(ParseObstacleSpecs(text, &specs, &error)) << text << ": " << error;
  return specs;
}

// The error of a text that must be refused, with no spec appended.
std::string Refusal(const std::string& text) {
  std::vector<ObstacleSpec> specs;
  std::string error;
  EXPECT_FALSE(ParseObstacleSpecs(text, &specs, &error)) << text;
  return error;
}

TEST(ParseObstacleSpecsTest, ReadsPathsRangesAndBones) {
  const std::vector<ObstacleSpec> specs =
      Parse("teeth.obj vertices=0:2208, teeth.obj  vertices=2208:4412\tbone=jaw,skull.obj");
  ASSERT_EQ(specs.size(), 3u);
  EXPECT_EQ(specs[0].path, "teeth.obj");
  EXPECT_EQ(specs[0].first_vertex, 0);
  EXPECT_EQ(specs[0].end_vertex, 2208);
  EXPECT_EQ(specs[0].bone, "");
  EXPECT_EQ(specs[1].path, "teeth.obj");
  EXPECT_EQ(specs[1].first_vertex, 2208);
  EXPECT_EQ(specs[1].end_vertex, 4412);
  EXPECT_EQ(specs[1].bone, "jaw");
  EXPECT_EQ(specs[2].path, "skull.obj");
  EXPECT_EQ(specs[2].first_vertex, 0);
  EXPECT_EQ(specs[2].end_vertex, -1);
  EXPECT_TRUE(Parse("").empty());
  EXPECT_EQ(Parse("teeth.obj,").size(), 1u);  // a trailing comma opens no item
}

TEST(ParseObstacleSpecsTest, AQuotedPathMayHoldSpacesAndCommas) {
  const std::vector<ObstacleSpec> specs =
      Parse("\"My Scans/teeth, lower.obj\" bone=jaw, /data/\"upper teeth\".obj vertices=1:3");
  ASSERT_EQ(specs.size(), 2u);
  EXPECT_EQ(specs[0].path, "My Scans/teeth, lower.obj");
  EXPECT_EQ(specs[0].bone, "jaw");
  EXPECT_EQ(specs[1].path, "/data/upper teeth.obj");
  EXPECT_EQ(specs[1].first_vertex, 1);
  EXPECT_EQ(specs[1].end_vertex, 3);
}

TEST(ParseObstacleSpecsTest, RefusesMalformedItemsNamingThem) {
  EXPECT_EQ(Refusal("a.obj,, b.obj"), "obstacles 'a.obj,, b.obj': an empty item (between commas)");
  EXPECT_EQ(Refusal("a.obj, "), "obstacles 'a.obj, ': an empty item (between commas)");
  EXPECT_EQ(Refusal("\"\" bone=jaw"), "obstacle '\"\" bone=jaw': the path is empty");
  EXPECT_EQ(Refusal("\"a b.obj bone=jaw"),
            "obstacles '\"a b.obj bone=jaw': a double quote is not closed");
  EXPECT_EQ(Refusal("a.obj bone=jaw bone=skull"),
            "obstacle 'a.obj bone=jaw bone=skull': 'bone=' is given twice");
  EXPECT_EQ(Refusal("a.obj bone="), "obstacle 'a.obj bone=': bone= needs the bone's name");
  EXPECT_EQ(Refusal("My Scans/a.obj"),
            "obstacle 'My Scans/a.obj': 'Scans/a.obj' after the path (a path with spaces or "
            "commas goes in double quotes)");
  EXPECT_EQ(Refusal("a.obj colour=red"),
            "obstacle 'a.obj colour=red': unknown field 'colour=red' (expected: path "
            "[vertices=a:b] [bone=name])");
  for (const std::string range : {"1:1", "-1:3", "3:2", "1", "1:x", ":3"}) {
    EXPECT_EQ(Refusal("a.obj vertices=" + range),
              "obstacle 'a.obj vertices=" + range + "': vertices=a:b needs 0 <= a < b");
  }
}

}  // namespace
}  // namespace aqs
