#ifndef AQS_UTIL_NUMBER_FORMAT_H_
#define AQS_UTIL_NUMBER_FORMAT_H_

#include <string>

namespace aqs {

// Formats a double with 17 significant digits ("%.17g"), enough to read back the
// exact same double. Every number the project writes to a file goes through this.
std::string FormatDouble(double value);

// Appends FormatDouble(value) to *out (no allocation of a temporary string).
void AppendDouble(double value, std::string* out);

}  // namespace aqs

#endif  // AQS_UTIL_NUMBER_FORMAT_H_
