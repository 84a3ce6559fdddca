// Progress lines (train/progress.h): durations as people read them, and the time left.

#include "train/progress.h"

#include <limits>
#include <sstream>

#include <ceres/iteration_callback.h>
#include <gtest/gtest.h>

namespace aqs {
namespace {

TEST(ProgressTest, DurationsReadAsSecondsMinutesOrHours) {
  EXPECT_EQ(FormatDuration(0.0), "0.0 s");
  EXPECT_EQ(FormatDuration(12.34), "12.3 s");
  EXPECT_EQ(FormatDuration(59.94), "59.9 s");
  EXPECT_EQ(FormatDuration(60.0), "1:00");
  EXPECT_EQ(FormatDuration(245.4), "4:05");
  EXPECT_EQ(FormatDuration(3600.0), "1:00:00");
  EXPECT_EQ(FormatDuration(5025.0), "1:23:45");
  EXPECT_EQ(FormatDuration(-1.0), "?");
  EXPECT_EQ(FormatDuration(std::numeric_limits<double>::quiet_NaN()), "?");
  EXPECT_EQ(FormatDuration(std::numeric_limits<double>::infinity()), "?");
  EXPECT_EQ(FormatDuration(1e30), "> 30 years");
}

TEST(ProgressTest, TheTimeLeftGrowsWithTheStepsLeft) {
  EXPECT_DOUBLE_EQ(EstimateRemaining(10, 40, 5.0), 15.0);
  EXPECT_DOUBLE_EQ(EstimateRemaining(40, 40, 5.0), 0.0);
  EXPECT_DOUBLE_EQ(EstimateRemaining(50, 40, 5.0), 0.0);
  EXPECT_LT(EstimateRemaining(0, 40, 5.0), 0.0);  // nothing done: unknown
}

// A run resumed after 4 of 10 iterations: its ETA counts only its own 6 (after 2 of them
// in 1 s, 4 more at 0.5 s), capped by a time budget, unknown before its first iteration
// (the pre-training's and the auto-encoder's lines counted all 10).
TEST(ProgressTest, AResumedRunsEtaCountsOnlyItsOwnIterations) {
  EXPECT_DOUBLE_EQ(ProgressEta(2, 10, 4, 1.0, -1.0), 2.0);
  EXPECT_DOUBLE_EQ(ProgressEta(6, 10, 4, 3.0, -1.0), 0.0);
  EXPECT_DOUBLE_EQ(ProgressEta(2, 10, 4, 1.0, 1.5), 0.5);
  EXPECT_DOUBLE_EQ(ProgressEta(2, 10, 4, 2.0, 1.5), 0.0);
  EXPECT_LT(ProgressEta(0, 10, 4, 0.5, 1.5), 0.0);
  EXPECT_DOUBLE_EQ(ProgressEta(2, 10, 0, 1.0, -1.0), 4.0);  // a fresh run
}

// With a time budget the ETA is at most what is left of it (pre-training's said 2:39:08
// and stopped at 6 s).
TEST(ProgressTest, TheTimeBudgetCapsTheEta) {
  std::ostringstream log;
  ProgressLogger progress("pretrain", 1, 2000000000, log, 0, 2.0);
  ceres::IterationSummary summary;
  summary.iteration = 1;
  progress(summary);
  EXPECT_NE(log.str().find("ETA 2.0 s"), std::string::npos) << log.str();
  // A budget used up by earlier runs: nothing left.
  std::ostringstream spent;
  ProgressLogger used_up("pretrain", 1, 2000000000, spent, 0, 0.0);
  used_up(summary);
  EXPECT_NE(spent.str().find("ETA 0.0 s"), std::string::npos) << spent.str();
  std::ostringstream unbounded;
  ProgressLogger open("pretrain", 1, 2000000000, unbounded);
  open(summary);
  EXPECT_EQ(unbounded.str().find("ETA 2.0 s"), std::string::npos) << unbounded.str();
}

TEST(ProgressTest, LinesEveryKIterationsCountingAResumedRun) {
  std::ostringstream log;
  ProgressLogger progress("train", 2, 10, log, 4);
  ceres::IterationSummary summary;
  summary.cost = 0.5;
  summary.gradient_norm = 0.25;
  for (int i = 0; i <= 3; ++i) {
    summary.iteration = i;
    EXPECT_EQ(progress(summary), ceres::SOLVER_CONTINUE);
  }
  const std::string text = log.str();
  EXPECT_NE(text.find("  train iter     4/10  loss 5.000000e-01  |g| 2.500e-01"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("  train iter     6/10"), std::string::npos) << text;
  EXPECT_EQ(text.find("iter     5/10"), std::string::npos) << text;
  EXPECT_EQ(text.find("iter     7/10"), std::string::npos) << text;
}

}  // namespace
}  // namespace aqs
