#ifndef AQS_UTIL_MEMORY_LIMIT_H_
#define AQS_UTIL_MEMORY_LIMIT_H_

#include <string>

namespace aqs {

// The default memory limit of the jobs that estimate their memory before allocating
// (the prepare job's lattice and simulations, pre-training's decoder): 8 GB, well above
// what the documented data need (the full face: about 2 GB), below what a mistyped
// flag asks for (--spacing=0.005, --hidden=1000000). The apps' --max_memory_gb sets it.
constexpr double kDefaultMaxMemoryBytes = 8e9;

// "812 MB", "12.3 GB" (decimal units).
std::string FormatBytes(double bytes);

// Checks an estimate against the limit, before the allocation it estimates. Returns
// false with *error "max_memory_bytes (8 GB) is below the estimated N GB that <what>
// needs (<details>); raise the limit to proceed" if estimate > limit (or either is not
// a number). The message starts with the field's name, so apps name their flag
// (--max_memory_gb) instead.
bool CheckMemoryEstimate(double estimate_bytes, double limit_bytes, const std::string& what,
                         const std::string& details, std::string* error);

}  // namespace aqs

#endif  // AQS_UTIL_MEMORY_LIMIT_H_
