#include "apps/run_command.h"

#include <sys/wait.h>

#include <array>
#include <cstdio>

namespace aqs {
namespace testing {

CommandResult RunCommand(const std::string& command) {
  CommandResult result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer;
  size_t n = 0;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

std::string AppPath(const std::string& name) {
  return std::string(AQS_BINARY_DIR) + "/apps/" + name;
}

std::string DataPath(const std::string& relative) {
  return std::string(AQS_SOURCE_DIR) + "/data/" + relative;
}

}  // namespace testing
}  // namespace aqs
