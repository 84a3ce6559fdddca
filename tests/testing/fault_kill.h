#ifndef AQS_TESTING_FAULT_KILL_H_
#define AQS_TESTING_FAULT_KILL_H_

#include <functional>
#include <string>
#include <vector>

namespace aqs {
namespace testing {

// The names of the util/fault_injection.h points that `body` passes, in order, when
// run in this process.
std::vector<std::string> FaultPointsOf(const std::function<void()>& body);

// Runs `body` in a forked child process that kills itself with SIGKILL (as kill -9
// would: no destructor, no cleanup) when it reaches its `n`-th fault point (0-based;
// n < 0: never). Returns "killed" if it was killed, else "exit <status>" (0 when body
// returned true).
std::string RunInChildKilledAt(int n, const std::function<bool()>& body);

// The same, killed when it reaches the point named `point` for the `occurrence`-th time
// (0-based).
std::string RunInChildKilledAt(const std::string& point, int occurrence,
                               const std::function<bool()>& body);

// Runs the program argv[0] with arguments argv[1..] (fork and exec: a fresh process,
// whose OpenMP and BLAS thread pools work, unlike a forked copy of a test process that
// used them). Returns "killed" if it ended by SIGKILL, else "exit <status>".
std::string RunProgram(const std::vector<std::string>& argv);

// In a child of RunInChildKilledAt: limits this process's address space to what it maps
// now plus `headroom` bytes (setrlimit RLIMIT_AS), so that an allocation beyond that fails
// (std::bad_alloc, or a library's out-of-memory error). False if it cannot.
bool LimitAddressSpaceToCurrentPlus(long headroom);

// The pid of a process that has ended (forked, exited and reaped).
long DeadPid();

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_FAULT_KILL_H_
