#ifndef AQS_TRAIN_PROGRESS_H_
#define AQS_TRAIN_PROGRESS_H_

#include <ostream>
#include <string>

namespace aqs {

// "1:23:45" / "4:05" / "12.3 s" for a duration in seconds (negative: "?").
std::string FormatDuration(double seconds);

// The estimated time left after `done` of `total` steps took `elapsed` seconds.
double EstimateRemaining(int done, int total, double elapsed);

}  // namespace aqs

#endif  // AQS_TRAIN_PROGRESS_H_
