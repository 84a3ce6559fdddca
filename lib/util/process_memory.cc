#include "util/process_memory.h"

#include <fstream>
#include <string>

namespace aqs {
namespace {

double ReadStatusKilobytes(const std::string& key) {
  std::ifstream in("/proc/self/status");
  std::string name;
  while (in >> name) {
    if (name == key) {
      double kb = 0;
      in >> kb;
      return kb * 1024.0;
    }
    std::string rest;
    std::getline(in, rest);
  }
  return 0;
}

}  // namespace

double PeakResidentBytes() { return ReadStatusKilobytes("VmHWM:"); }
double CurrentResidentBytes() { return ReadStatusKilobytes("VmRSS:"); }

}  // namespace aqs
