#ifndef AQS_UTIL_WALL_TIMER_H_
#define AQS_UTIL_WALL_TIMER_H_

#include <chrono>

namespace aqs {

// Wall-clock stopwatch started at construction or Reset(); Seconds() is elapsed time.
class WallTimer {
 public:
  WallTimer() : start_(std::chrono::steady_clock::now()) {}
  void Reset() { start_ = std::chrono::steady_clock::now(); }
  double Seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

}  // namespace aqs

#endif  // AQS_UTIL_WALL_TIMER_H_
