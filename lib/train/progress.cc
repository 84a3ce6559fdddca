#include "train/progress.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace aqs {

std::string FormatDuration(double seconds) {
  if (!(seconds >= 0) || !std::isfinite(seconds)) return "?";
  if (seconds >= 1e9) return "> 30 years";  // (lround would overflow far beyond)
  char text[32];
  if (seconds < 60) {
    std::snprintf(text, sizeof(text), "%.1f s", seconds);
  } else {
    const long s = std::lround(seconds);
    if (s >= 3600) {
      std::snprintf(text, sizeof(text), "%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
    } else {
      std::snprintf(text, sizeof(text), "%ld:%02ld", s / 60, s % 60);
    }
  }
  return text;
}

double EstimateRemaining(int done, int total, double elapsed) {
  if (done <= 0) return -1.0;
  return elapsed / done * std::max(0, total - done);
}

double ProgressEta(int done_here, int total, int done_before, double elapsed,
                   double seconds_left) {
  double remaining = EstimateRemaining(done_here, total - done_before, elapsed);
  if (seconds_left >= 0) remaining = std::min(remaining, std::max(0.0, seconds_left - elapsed));
  return remaining;
}

ceres::CallbackReturnType ProgressLogger::operator()(const ceres::IterationSummary& s) {
  if (every_ > 0 && (s.iteration % every_ == 0)) {
    const double elapsed = timer_.Seconds();
    const double remaining =
        ProgressEta(s.iteration, total_, done_before_, elapsed, seconds_left_);
    char line[320];
    std::snprintf(line, sizeof(line), "  %s iter %5d/%d  loss %.6e  |g| %.3e  %s  ETA %s\n",
                  label_.c_str(), done_before_ + s.iteration, total_, s.cost, s.gradient_norm,
                  FormatDuration(elapsed).c_str(), FormatDuration(remaining).c_str());
    log_ << line << std::flush;
  }
  return ceres::SOLVER_CONTINUE;
}

}  // namespace aqs
