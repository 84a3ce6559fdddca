#include "jobs/report_script.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>

extern char** environ;

namespace aqs {
namespace {

// The file `name` runs as: itself if it has a slash, else the first executable regular
// file of that name in PATH's folders (an empty entry is the working folder); "" if none.
std::string FindProgram(const std::string& name) {
  auto runnable = [](const std::string& path) {
    struct stat info;
    return ::stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode) &&
           ::access(path.c_str(), X_OK) == 0;
  };
  if (name.find('/') != std::string::npos) return name;
  const char* path_variable = std::getenv("PATH");
  const std::string path =
      path_variable != nullptr ? path_variable : "/usr/local/bin:/usr/bin:/bin";
  size_t begin = 0;
  while (begin <= path.size()) {
    size_t end = path.find(':', begin);
    if (end == std::string::npos) end = path.size();
    const std::string folder = path.substr(begin, end - begin);
    const std::string candidate = (folder.empty() ? std::string(".") : folder) + "/" + name;
    if (runnable(candidate)) return candidate;
    begin = end + 1;
  }
  return "";
}

}  // namespace

int RunProgram(const std::vector<std::string>& command, std::string* message) {
  if (command.empty()) {
    *message = "no program given";
    return -1;
  }
  std::vector<char*> argv;
  for (const std::string& arg : command) argv.push_back(const_cast<char*>(arg.c_str()));
  argv.push_back(nullptr);
  const std::string program = FindProgram(command[0]);
  if (program.empty()) {
    *message = "cannot run '" + command[0] + "': " + std::strerror(ENOENT);
    return -1;
  }
  std::cout.flush();
  std::cerr.flush();
  const pid_t parent = ::getpid();
  const char* path = program.c_str();
  char* const* arguments = argv.data();
  // vfork, as posix_spawn does: no copy of a large process's memory (which fork may be
  // refused under strict overcommit), and no fork warnings from MPI libraries. The child
  // only makes system calls. It reports a failed exec's errno through a pipe that a
  // successful exec closes (O_CLOEXEC): writing it into memory shared with this process
  // is undefined, and was lost where vfork is a fork (ThreadSanitizer's).
  int error_pipe[2];
  if (::pipe2(error_pipe, O_CLOEXEC) != 0) {
    *message = "cannot run '" + command[0] + "': " + std::strerror(errno);
    return -1;
  }
  const pid_t pid = ::vfork();
  if (pid < 0) {
    *message = "cannot run '" + command[0] + "': " + std::strerror(errno);
    ::close(error_pipe[0]);
    ::close(error_pipe[1]);
    return -1;
  }
  if (pid == 0) {
    // The child dies with the process that started it: a killed evaluation must not
    // leave its report script writing into the folder that the next run takes over.
    ::prctl(PR_SET_PDEATHSIG, SIGKILL);
    if (::getppid() != parent) ::_exit(127);
    ::execve(path, arguments, environ);
    const int failure = errno;
    const ssize_t written = ::write(error_pipe[1], &failure, sizeof failure);
    ::_exit(written == sizeof failure ? 127 : 126);
  }
  ::close(error_pipe[1]);
  int exec_errno = 0;
  ssize_t got;
  do {
    got = ::read(error_pipe[0], &exec_errno, sizeof exec_errno);
  } while (got < 0 && errno == EINTR);
  ::close(error_pipe[0]);
  if (got != static_cast<ssize_t>(sizeof exec_errno)) exec_errno = 0;  // the exec succeeded
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) {
      *message = "waiting for '" + command[0] + "' failed: " + std::strerror(errno);
      return -1;
    }
  }
  if (exec_errno != 0) {
    *message = "cannot run '" + command[0] + "' (" + program + "): " + std::strerror(exec_errno);
    return -1;
  }
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  *message = "'" + command[0] + "' was killed by signal " + std::to_string(WTERMSIG(status));
  return kKilledBySignal;
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
  if (status == kKilledBySignal) {  // not a missing package: say what happened
    log << "report: no pictures or HTML page: the report script " << message << "; " << written
        << "\n";
  } else if (status == -1 || status == 127) {
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
