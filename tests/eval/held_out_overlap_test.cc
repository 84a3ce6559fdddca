#include "eval/held_out_overlap.h"

#include <gtest/gtest.h>

namespace aqs {
namespace {

Eigen::Matrix3Xd Shifted(const Eigen::Matrix3Xd& points, double dx) {
  Eigen::Matrix3Xd out = points;
  out.row(0).array() += dx;
  return out;
}

// Held out: a copy of a training pose (reported), one that differs from its nearest
// training pose by 10% of its motion (not reported at 5%), and the neutral (never).
TEST(HeldOutOverlapTest, ReportsCopiesOfTrainingPosesOnly) {
  Eigen::Matrix3Xd neutral = Eigen::Matrix3Xd::Random(3, 50);
  const std::vector<Eigen::Matrix3Xd> training = {neutral, Shifted(neutral, 1.0),
                                                  Shifted(neutral, -2.0)};
  const std::vector<Eigen::Matrix3Xd> held_out = {Shifted(neutral, -2.0 + 1e-4),
                                                  Shifted(neutral, 1.1), neutral};
  const std::vector<HeldOutOverlap> overlaps = FindHeldOutOverlaps(neutral, training, held_out, {});
  ASSERT_EQ(overlaps.size(), 1u);
  EXPECT_EQ(overlaps[0].test, 0);
  EXPECT_EQ(overlaps[0].training, 2);
  EXPECT_NEAR(overlaps[0].distance, 1e-4, 1e-12);
  EXPECT_NEAR(overlaps[0].motion, 2.0 - 1e-4, 1e-12);
  // At 20%, the second is reported too (0.1 from the training pose, moving 1.1).
  EXPECT_EQ(FindHeldOutOverlaps(neutral, training, held_out, {}, 0.2).size(), 2u);
}

// Only the given vertices count: a pose that differs from a training pose outside them
// is a copy within them.
TEST(HeldOutOverlapTest, MeasuresOverTheGivenVertices) {
  const Eigen::Matrix3Xd neutral = Eigen::Matrix3Xd::Zero(3, 4);
  Eigen::Matrix3Xd pose = neutral;
  pose.col(0) << 1, 0, 0;
  Eigen::Matrix3Xd held = pose;
  held.col(3) << 0, 0, 5;
  EXPECT_TRUE(FindHeldOutOverlaps(neutral, {pose}, {held}, {}).empty());
  const std::vector<HeldOutOverlap> overlaps =
      FindHeldOutOverlaps(neutral, {pose}, {held}, {0, 1, 2});
  ASSERT_EQ(overlaps.size(), 1u);
  EXPECT_EQ(overlaps[0].distance, 0.0);
}

}  // namespace
}  // namespace aqs
