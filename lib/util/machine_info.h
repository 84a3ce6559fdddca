#ifndef AQS_UTIL_MACHINE_INFO_H_
#define AQS_UTIL_MACHINE_INFO_H_

#include <string>

namespace aqs {

// What a benchmark prints about the machine it ran on, read from the system (Linux).
// "<host>: <n> cores, <processor model name>" ("unknown processor" without
// /proc/cpuinfo).
std::string MachineDescription();

// The 1, 5 and 15 minute load averages of /proc/loadavg, as "a b c" ("unknown" if
// unreadable).
std::string LoadAverage();

// One line that opens a benchmark's output: "machine <MachineDescription()>; load average
// <LoadAverage()>; <UTC date and time, YYYY-MM-DD HH:MM UTC>" (no newline): what
// docs/ records beside the figures.
std::string BenchmarkMachineLine();

// Processor seconds this process has used so far, over all its threads.
double ProcessCpuSeconds();

}  // namespace aqs

#endif  // AQS_UTIL_MACHINE_INFO_H_
