#include "jobs/report_script.h"

#include <spawn.h>
#include <sys/wait.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iostream>

extern char** environ;

namespace aqs {

int RunProgram(const std::vector<std::string>& command, std::string* message) {
  if (command.empty()) {
    *message = "no program given";
    return -1;
  }
  std::vector<char*> argv;
  for (const std::string& arg : command) argv.push_back(const_cast<char*>(arg.c_str()));
  argv.push_back(nullptr);
  std::cout.flush();
  std::cerr.flush();
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, argv[0], nullptr, nullptr, argv.data(), environ);
  if (spawned != 0) {
    *message = "cannot run '" + command[0] + "': " + std::strerror(spawned);
    return -1;
  }
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      *message = "waiting for '" + command[0] + "' failed: " + std::strerror(errno);
      return -1;
    }
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  *message = "'" + command[0] + "' was killed by signal " + std::to_string(WTERMSIG(status));
  return -1;
}

bool RunReportScript(const std::string& python, const std::string& script,
                     const std::vector<std::string>& arguments, std::ostream& log) {
  const std::string written = "the tables and fields were written";
  std::error_code code;
  if (!std::filesystem::is_regular_file(script, code)) {
    log << "report: no pictures or HTML page: the report script " << script
        << " is missing (--report_script); " << written << "\n";
    return false;
  }
  std::vector<std::string> command = {python, script};
  command.insert(command.end(), arguments.begin(), arguments.end());
  log << "report: " << python << " " << script << "\n" << std::flush;
  std::string message;
  const int status = RunProgram(command, &message);
  if (status == 0) return true;
  if (status == -1 || status == 127) {
    log << "report: no pictures or HTML page: "
        << (status == -1 ? message : "cannot run '" + python + "'")
        << " (--python; install python3, python3-matplotlib and python3-numpy); " << written
        << "\n";
  } else if (status == kReportMissingPackageStatus) {
    log << "report: no pictures or HTML page: " << python
        << " lacks matplotlib or numpy: install python3-matplotlib and python3-numpy "
           "(scripts/install_deps.sh), or pass a --python that has them; "
        << written << "\n";
  } else {
    log << "report: the report script failed (exit status " << status << ", its message is "
        << "above); " << written << "\n";
  }
  return false;
}

}  // namespace aqs
