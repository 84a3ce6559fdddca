#include "util/machine_info.h"

#include <time.h>
#include <unistd.h>

#include <fstream>
#include <string>

namespace aqs {

std::string MachineDescription() {
  char host[256] = "?";
  if (gethostname(host, sizeof(host) - 1) != 0) host[0] = '?', host[1] = '\0';
  host[sizeof(host) - 1] = '\0';
  std::string processor = "unknown processor";
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);) {
    const size_t colon = line.find(':');
    if (line.rfind("model name", 0) == 0 && colon != std::string::npos &&
        colon + 2 <= line.size()) {
      processor = line.substr(colon + 2);
      break;
    }
  }
  return std::string(host) + ": " + std::to_string(sysconf(_SC_NPROCESSORS_ONLN)) + " cores, " +
         processor;
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string one, five, fifteen;
  if (!(in >> one >> five >> fifteen)) return "unknown";
  return one + " " + five + " " + fifteen;
}

std::string BenchmarkMachineLine() {
  char date[64] = "unknown date";
  const time_t now = time(nullptr);
  tm utc;
  if (gmtime_r(&now, &utc) != nullptr) strftime(date, sizeof(date), "%Y-%m-%d %H:%M UTC", &utc);
  return "machine " + MachineDescription() + "; load average " + LoadAverage() + "; " + date;
}

double ProcessCpuSeconds() {
  timespec t;
  if (clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t) != 0) return 0.0;
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace aqs
