#include "util/text_split.h"

#include <gtest/gtest.h>

#include "util/file_extension.h"

namespace aqs {
namespace {

using Strings = std::vector<std::string>;

TEST(TextSplitTest, SplitListDropsEmptyItems) {
  EXPECT_EQ(SplitList("a,b,,c"), (Strings{"a", "b", "c"}));
  EXPECT_EQ(SplitList(",a, b,"), (Strings{"a", " b"}));
  EXPECT_EQ(SplitList(""), Strings());
  EXPECT_EQ(SplitList(",,"), Strings());
  EXPECT_EQ(SplitList("x;y;;z", ';'), (Strings{"x", "y", "z"}));
  EXPECT_EQ(SplitList("x,y;z", ';'), (Strings{"x,y", "z"}));
}

TEST(TextSplitTest, SplitFieldsKeepsEmptyFieldsAsGetlineDoes) {
  EXPECT_EQ(SplitFields("a,,b"), (Strings{"a", "", "b"}));
  EXPECT_EQ(SplitFields(",a"), (Strings{"", "a"}));
  EXPECT_EQ(SplitFields("a,"), (Strings{"a"}));
  EXPECT_EQ(SplitFields(","), (Strings{""}));
  EXPECT_EQ(SplitFields(""), Strings());
  EXPECT_EQ(SplitFields("1;2", ';'), (Strings{"1", "2"}));
}

TEST(TextSplitTest, JoinIntsIsTheInverseOfSplittingAList) {
  EXPECT_EQ(JoinInts({64, 64}), "64,64");
  EXPECT_EQ(JoinInts({-3}), "-3");
  EXPECT_EQ(JoinInts({}), "");
  EXPECT_EQ(JoinInts({}, "none"), "none");
  EXPECT_EQ(SplitList(JoinInts({8, 16, 32})), std::vector<std::string>({"8", "16", "32"}));
}

TEST(FileExtensionTest, LowerCaseWithDotAsFilesystemTakesIt) {
  EXPECT_EQ(LowercaseExtension("dir.d/Mesh.MSH"), ".msh");
  EXPECT_EQ(LowercaseExtension("a/b.tar.GZ"), ".gz");
  EXPECT_EQ(LowercaseExtension("dir.d/mesh"), "");
  EXPECT_EQ(LowercaseExtension("dir/.obj"), "");
  EXPECT_EQ(LowercaseExtension("a.obj/"), "");
  EXPECT_EQ(LowercaseExtension("out."), ".");
  EXPECT_EQ(LowercaseExtension("Pose.Obj"), ".obj");
}

TEST(TextSplitTest, OneLineReplacesLineBreaksBySpaces) {
  EXPECT_EQ(OneLine("a\nb\r\nc"), "a b  c");
  EXPECT_EQ(OneLine(""), "");
  EXPECT_EQ(OneLine("no break"), "no break");
}

}  // namespace
}  // namespace aqs
