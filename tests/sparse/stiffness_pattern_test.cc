#include "sparse/stiffness_pattern.h"

#include <cmath>
#include <limits>
#include <vector>

#include <gtest/gtest.h>

namespace aqs {
namespace {

// The largest free-vertex norm skips the fixed vertices, and a NaN column of a free
// vertex makes it NaN (std::max dropped it, and a force test could then pass).
TEST(StiffnessPatternTest, MaxFreeVertexNormSkipsFixedVerticesAndKeepsNaN) {
  Eigen::Matrix4Xi tets(4, 1);
  tets << 0, 1, 2, 3;
  const StiffnessPattern pattern(tets, {false, true, false, false});
  Eigen::Matrix3Xd field = Eigen::Matrix3Xd::Zero(3, 4);
  field.col(0) << 3, 4, 0;   // 5
  field.col(1) << 0, 0, 9;   // fixed
  field.col(3) << 0, 0, -2;  // 2
  EXPECT_EQ(MaxFreeVertexNorm(pattern, field), 5.0);
  field(1, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(std::isnan(MaxFreeVertexNorm(pattern, field)));
  field.col(0).setConstant(std::numeric_limits<double>::quiet_NaN());
  field(1, 2) = 0.0;
  EXPECT_TRUE(std::isnan(MaxFreeVertexNorm(pattern, field)));
}

}  // namespace
}  // namespace aqs
