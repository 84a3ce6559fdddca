#ifndef AQS_TESTING_RUN_COMMAND_H_
#define AQS_TESTING_RUN_COMMAND_H_

#include <string>
#include <vector>

namespace aqs {
namespace testing {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// Runs `command` with /bin/sh, capturing its output.
CommandResult RunCommand(const std::string& command);

// Starts the program argv[0] with arguments argv[1..] in the background (fork and exec),
// its stdout and stderr going to the file `output`. Returns its pid (-1 on failure);
// the caller ends it with WaitForCommand.
int StartCommand(const std::vector<std::string>& argv, const std::string& output);
// Waits for a started program: "killed" if SIGKILL ended it, else "exit <status>".
std::string WaitForCommand(int pid);

// Path of an app binary built with the tests.
std::string AppPath(const std::string& name);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_RUN_COMMAND_H_
