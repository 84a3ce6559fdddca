#ifndef AQS_UTIL_PROCESS_MEMORY_H_
#define AQS_UTIL_PROCESS_MEMORY_H_

namespace aqs {

// Peak resident set size of this process so far, in bytes (VmHWM from
// /proc/self/status); 0 where that is unavailable.
double PeakResidentBytes();
// Current resident set size in bytes (VmRSS); 0 where unavailable.
double CurrentResidentBytes();

}  // namespace aqs

#endif  // AQS_UTIL_PROCESS_MEMORY_H_
