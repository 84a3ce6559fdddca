#include "testing/fault_kill.h"

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>

#include "util/fault_injection.h"

namespace aqs {
namespace testing {
namespace {

std::vector<std::string>* g_names = nullptr;
int g_countdown = -1;

void RecordPoint(const char* point) { g_names->push_back(point); }

const std::string* g_point = nullptr;

void KillAtPoint(const char* point) {
  if ((g_point == nullptr || *g_point == point) && g_countdown-- == 0) ::raise(SIGKILL);
}

std::string Wait(pid_t pid) {
  if (pid < 0) return "fork failed";
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL) return "killed";
  if (WIFEXITED(status)) return "exit " + std::to_string(WEXITSTATUS(status));
  return "status " + std::to_string(status);
}

std::string RunInChild(const std::string* point, int n, const std::function<bool()>& body) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    g_countdown = n;
    g_point = point;
    SetFaultHookForTesting(n >= 0 ? &KillAtPoint : nullptr);
    ::_exit(body() ? 0 : 1);
  }
  return Wait(pid);
}

}  // namespace

std::vector<std::string> FaultPointsOf(const std::function<void()>& body) {
  std::vector<std::string> names;
  g_names = &names;
  const FaultHook previous = SetFaultHookForTesting(&RecordPoint);
  body();
  SetFaultHookForTesting(previous);
  g_names = nullptr;
  return names;
}

std::string RunInChildKilledAt(int n, const std::function<bool()>& body) {
  return RunInChild(nullptr, n, body);
}

std::string RunInChildKilledAt(const std::string& point, int occurrence,
                               const std::function<bool()>& body) {
  return RunInChild(&point, occurrence, body);
}

std::string RunProgram(const std::vector<std::string>& argv) {
  std::vector<char*> args;
  for (const std::string& arg : argv) args.push_back(const_cast<char*>(arg.c_str()));
  args.push_back(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  return Wait(pid);
}

long DeadPid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return static_cast<long>(pid);
}

bool LimitAddressSpaceToCurrentPlus(long headroom) {
  std::ifstream statm("/proc/self/statm");
  long pages = 0;
  statm >> pages;
  if (pages <= 0) return false;
  struct rlimit limit;
  limit.rlim_cur = limit.rlim_max =
      static_cast<rlim_t>(pages) * static_cast<rlim_t>(sysconf(_SC_PAGESIZE)) +
      static_cast<rlim_t>(headroom);
  return setrlimit(RLIMIT_AS, &limit) == 0;
}

}  // namespace testing
}  // namespace aqs
