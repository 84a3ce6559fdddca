#ifndef AQS_UTIL_NUMBER_FORMAT_H_
#define AQS_UTIL_NUMBER_FORMAT_H_

#include <string>

namespace aqs {

// Formats a double as the shortest decimal text that reads back as the exact same double
// (std::to_chars; for example "0.1", "1e-07", "-2.5e-300"). Every number the project
// writes to a file goes through this.
std::string FormatDouble(double value);

// Appends FormatDouble(value) to *out (no allocation of a temporary string).
void AppendDouble(double value, std::string* out);

}  // namespace aqs

#endif  // AQS_UTIL_NUMBER_FORMAT_H_
