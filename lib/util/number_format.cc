#include "util/number_format.h"

#include <cstdio>

namespace aqs {

void AppendDouble(double value, std::string* out) {
  char buffer[32];
  const int n = std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  out->append(buffer, n);
}

std::string FormatDouble(double value) {
  std::string out;
  AppendDouble(value, &out);
  return out;
}

}  // namespace aqs
