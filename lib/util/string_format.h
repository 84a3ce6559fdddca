#ifndef AQS_UTIL_STRING_FORMAT_H_
#define AQS_UTIL_STRING_FORMAT_H_

#include <string>

namespace aqs {

// printf's formatting into a string of any length (the benchmarks' tables). Numbers the
// project writes to data files go through util/number_format.h instead.
std::string StringPrintf(const char* format, ...) __attribute__((format(printf, 1, 2)));

}  // namespace aqs

#endif  // AQS_UTIL_STRING_FORMAT_H_
