// Names written as one field of the project's text files (util/name_rules.h).

#include "util/name_rules.h"

#include <string>

#include <gtest/gtest.h>

namespace aqs {
namespace {

TEST(NameRulesTest, OneWordWithoutCommentMarkOrComma) {
  for (const std::string good : {"jawOpen", "mouthSmile_L", "mix_000", "a.b-c+d", "x"}) {
    EXPECT_EQ(NameProblem(good), "") << good;
  }
  EXPECT_EQ(NameProblem(""), "is empty");
  EXPECT_EQ(NameProblem("smile#2").rfind("contains '#' (the model files' comment mark)", 0), 0u);
  EXPECT_EQ(NameProblem("a,b").rfind("contains ',' (the CSV files' separator)", 0), 0u);
  for (const std::string spaced : {"a b", "a\tb", "a\nb", "a\rb"}) {
    EXPECT_EQ(NameProblem(spaced).rfind("contains white space", 0), 0u) << spaced;
  }
}

}  // namespace
}  // namespace aqs
