#ifndef AQS_TRAIN_PROGRESS_H_
#define AQS_TRAIN_PROGRESS_H_

#include <ostream>
#include <string>
#include <utility>

#include <ceres/iteration_callback.h>

#include "util/wall_timer.h"

namespace aqs {

// "1:23:45" / "4:05" / "12.3 s" for a duration in seconds (negative or not finite: "?";
// 1e9 s or more: "> 30 years").
std::string FormatDuration(double seconds);

// The estimated time left after `done` of `total` steps took `elapsed` seconds.
double EstimateRemaining(int done, int total, double elapsed);

// The ETA a progress line prints: a run that resumes after `done_before` of `total`
// iterations has done `done_here` more in `elapsed` seconds; the estimate is for its own
// rest (total - done_before - done_here), at most what is left of a time budget of
// `seconds_left` (at the run's start; < 0: none). -1 (unknown) before its first iteration.
double ProgressEta(int done_here, int total, int done_before, double elapsed,
                   double seconds_left);

// A Ceres iteration callback that prints, every `every` iterations (0: never),
//   "  <label> iter    k/total  loss ...  |g| ...  <elapsed>  ETA <remaining>"
// to `log`, timed from construction. k counts from `done_before` (iterations of an
// earlier run this one resumes; the ETA is for the rest). With a time budget,
// `seconds_left` >= 0 (what is left of it at construction; < 0: no budget), the ETA is
// at most what is left of that. It never stops the solver.
class ProgressLogger final : public ceres::IterationCallback {
 public:
  ProgressLogger(std::string label, int every, int total, std::ostream& log,
                 int done_before = 0, double seconds_left = -1.0)
      : label_(std::move(label)),
        every_(every),
        total_(total),
        done_before_(done_before),
        seconds_left_(seconds_left),
        log_(log) {}
  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override;

 private:
  std::string label_;
  int every_, total_, done_before_;
  double seconds_left_;
  std::ostream& log_;
  WallTimer timer_;
};

}  // namespace aqs

#endif  // AQS_TRAIN_PROGRESS_H_
