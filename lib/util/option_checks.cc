#include "util/option_checks.h"

#include <cmath>
#include <sstream>

namespace aqs {

std::string OptionValue(double value) {
  std::ostringstream out;
  out.precision(6);
  out << value;
  return out.str();
}

OptionChecks& OptionChecks::Positive(const char* field, double value) {
  if (!Failed() && !(std::isfinite(value) && value > 0.0)) {
    error_ = std::string(field) + " must be finite and > 0 (is " + OptionValue(value) + ")";
  }
  return *this;
}

OptionChecks& OptionChecks::NonNegative(const char* field, double value) {
  if (!Failed() && !(std::isfinite(value) && value >= 0.0)) {
    error_ = std::string(field) + " must be finite and >= 0 (is " + OptionValue(value) + ")";
  }
  return *this;
}

OptionChecks& OptionChecks::InRange(const char* field, double value, double lowest,
                                    double highest) {
  if (!Failed() && !(std::isfinite(value) && value >= lowest && value <= highest)) {
    error_ = std::string(field) + " must be in [" + OptionValue(lowest) + ", " +
             OptionValue(highest) + "] (is " + OptionValue(value) + ")";
  }
  return *this;
}

OptionChecks& OptionChecks::IntInRange(const char* field, long long value, long long lowest,
                                       long long highest) {
  if (!Failed() && !(value >= lowest && value <= highest)) {
    error_ = std::string(field) + " must be in [" + std::to_string(lowest) + ", " +
             std::to_string(highest) + "] (is " + std::to_string(value) + ")";
  }
  return *this;
}

OptionChecks& OptionChecks::IntAtLeast(const char* field, long long value, long long lowest) {
  if (!Failed() && value < lowest) {
    error_ = std::string(field) + " must be >= " + std::to_string(lowest) + " (is " +
             std::to_string(value) + ")";
  }
  return *this;
}

OptionChecks& OptionChecks::ReachableTolerance(const char* field, double value) {
  if (!Failed() && value < kMinReachableRelativeTolerance) {
    error_ = std::string(field) + " must be >= " + OptionValue(kMinReachableRelativeTolerance) +
             " (is " + OptionValue(value) +
             "): below, the force test meets round-off and the solves may not end";
  } else if (!Failed() && !(value <= kMaxRelativeTolerance)) {
    error_ = std::string(field) + " must be at most " + OptionValue(kMaxRelativeTolerance) +
             " (is " + OptionValue(value) + "): above, a solve stops where it starts";
  }
  return *this;
}

OptionChecks& OptionChecks::Nested(const char* prefix, bool ok, const std::string& nested_error) {
  if (!Failed() && !ok) error_ = std::string(prefix) + "." + nested_error;
  return *this;
}

OptionChecks& OptionChecks::Require(bool condition, const std::string& message) {
  if (!Failed() && !condition) error_ = message;
  return *this;
}

bool OptionChecks::Done(std::string* error) const {
  *error = error_;
  return error_.empty();
}

}  // namespace aqs
