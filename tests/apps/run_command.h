#ifndef AQS_TESTS_APPS_RUN_COMMAND_H_
#define AQS_TESTS_APPS_RUN_COMMAND_H_

#include <string>

namespace aqs {
namespace testing {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Runs `command` with /bin/sh, capturing its output.
CommandResult RunCommand(const std::string& command);

// Path of an app binary built with the tests.
std::string AppPath(const std::string& name);
// Path of a file under the source tree's data/ folder.
std::string DataPath(const std::string& relative);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTS_APPS_RUN_COMMAND_H_
