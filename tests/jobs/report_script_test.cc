// RunProgram: exit statuses, a program that is not there, and a program that dies with
// the process that started it (a killed evaluation's report script must not go on
// writing into the folder the next run takes over).
#include "jobs/report_script.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "testing/temp_dir.h"

namespace aqs {
namespace {

// Whether process `pid` is gone: no such process, or a zombie nobody reaped yet.
bool Gone(pid_t pid) {
  if (::kill(pid, 0) != 0 && errno == ESRCH) return true;
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  if (!std::getline(stat, line)) return true;
  const size_t paren = line.rfind(')');
  return paren != std::string::npos && paren + 2 < line.size() && line[paren + 2] == 'Z';
}

TEST(RunProgramTest, ReturnsTheExitStatusAndNamesAMissingProgram) {
  std::string message;
  EXPECT_EQ(RunProgram({"sh", "-c", "exit 7"}, &message), 7) << message;
  EXPECT_EQ(RunProgram({"true"}, &message), 0) << message;
  EXPECT_EQ(RunProgram({"aqs_no_such_program_here"}, &message), -1);
  EXPECT_NE(message.find("cannot run 'aqs_no_such_program_here'"), std::string::npos)
      << message;
  EXPECT_EQ(RunProgram({"sh", "-c", "kill -9 $$"}, &message), kKilledBySignal);
  EXPECT_NE(message.find("killed by signal 9"), std::string::npos) << message;
  // A file that is there but cannot be executed: the exec's reason.
  testing::TempDir dir;
  const std::string bad = dir.File("not_a_program");
  std::ofstream(bad) << "\x7f" << "garbage\n";
  std::filesystem::permissions(bad, std::filesystem::perms::owner_all);
  EXPECT_EQ(RunProgram({bad}, &message), -1);
  EXPECT_NE(message.find("cannot run '" + bad + "' (" + bad + "): "), std::string::npos)
      << message;
}

// A report script that a signal ends is said to be: the log told the user to install
// python3, matplotlib and numpy.
TEST(RunProgramTest, AReportScriptKilledByASignalIsNotAMissingPackage) {
  testing::TempDir dir;
  const std::string script = dir.Write("report.sh", "kill -9 $$\n");
  std::ostringstream log;
  EXPECT_FALSE(RunReportScript("sh", script, {}, log));
  EXPECT_NE(log.str().find("'sh' was killed by signal 9"), std::string::npos) << log.str();
  EXPECT_EQ(log.str().find("install"), std::string::npos) << log.str();
}

TEST(RunProgramTest, TheProgramDiesWithTheProcessThatStartedIt) {
  testing::TempDir dir;
  const std::string pid_file = dir.File("pid.txt");
  const pid_t starter = ::fork();
  ASSERT_GE(starter, 0);
  if (starter == 0) {
    std::string message;
    RunProgram({"sh", "-c", "echo $$ > " + pid_file + ".part && mv " + pid_file + ".part " +
                                pid_file + " && exec sleep 60"},
               &message);
    ::_exit(0);
  }
  pid_t program = 0;
  for (int i = 0; i < 200 && program == 0; ++i) {
    std::ifstream in(pid_file);
    if (!(in >> program)) {
      program = 0;
      std::this_thread::sleep_for(std::chrono::milliseconds(25));
    }
  }
  ::kill(starter, SIGKILL);
  int status = 0;
  ::waitpid(starter, &status, 0);
  ASSERT_GT(program, 0) << "the program did not start";
  bool gone = false;
  for (int i = 0; i < 200 && !gone; ++i) {
    gone = Gone(program);
    if (!gone) std::this_thread::sleep_for(std::chrono::milliseconds(25));
  }
  if (!gone) ::kill(program, SIGKILL);
  EXPECT_TRUE(gone) << "the program outlived the process that started it";
}

}  // namespace
}  // namespace aqs
