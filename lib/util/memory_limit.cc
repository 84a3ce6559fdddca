#include "util/memory_limit.h"

#include <cmath>
#include <cstdio>

namespace aqs {

std::string FormatBytes(double bytes) {
  char text[64];
  if (!std::isfinite(bytes)) {
    std::snprintf(text, sizeof(text), "%g bytes", bytes);
  } else if (bytes >= 1e12) {
    std::snprintf(text, sizeof(text), "%.3g TB", bytes / 1e12);
  } else if (bytes >= 1e9) {
    std::snprintf(text, sizeof(text), "%.3g GB", bytes / 1e9);
  } else if (bytes >= 1e6) {
    std::snprintf(text, sizeof(text), "%.3g MB", bytes / 1e6);
  } else if (bytes >= 1e3) {
    std::snprintf(text, sizeof(text), "%.3g kB", bytes / 1e3);
  } else {
    std::snprintf(text, sizeof(text), "%.0f bytes", bytes);
  }
  return text;
}

bool CheckMemoryEstimate(double estimate_bytes, double limit_bytes, const std::string& what,
                         const std::string& details, std::string* error) {
  if (estimate_bytes <= limit_bytes) return true;  // false for NaN
  *error = "max_memory_bytes (" + FormatBytes(limit_bytes) + ") is below the estimated " +
           FormatBytes(estimate_bytes) + " that " + what + " needs" +
           (details.empty() ? std::string() : " (" + details + ")") +
           "; raise the limit to proceed";
  return false;
}

}  // namespace aqs
