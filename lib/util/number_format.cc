#include "util/number_format.h"

#include <charconv>
#include <system_error>

#include <glog/logging.h>

namespace aqs {

void AppendDouble(double value, std::string* out) {
  // std::to_chars without a precision writes the shortest text that reads back as the
  // same double; it is about ten times faster than "%.17g", which matters for the
  // decoder's million parameters written at every training checkpoint.
  char buffer[32];
  const std::to_chars_result result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  CHECK(result.ec == std::errc()) << "a double needs at most 24 characters";
  out->append(buffer, result.ptr - buffer);
}

std::string FormatDouble(double value) {
  std::string out;
  AppendDouble(value, &out);
  return out;
}

}  // namespace aqs
