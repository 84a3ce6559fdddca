#ifndef AQS_JOBS_REPORT_SCRIPT_H_
#define AQS_JOBS_REPORT_SCRIPT_H_

#include <ostream>
#include <string>
#include <vector>

namespace aqs {

// Exit status of scripts/evaluation_report.py when a Python package it needs
// (matplotlib, numpy) cannot be imported.
constexpr int kReportMissingPackageStatus = 3;

// Runs `command` (its program found through PATH when it has no slash), with the
// standard streams shared, and waits for it; the program is killed (SIGKILL) if this
// process dies first. std::cout and std::cerr are flushed first so that its lines
// follow. Returns the exit status (127: it could not be executed), -1 if the program was
// not found or could not be started, or kKilledBySignal if a signal ended it (*message
// says why, for both).
// Call it from the thread that lives as long as the process (Linux ties the child's
// death signal to the thread that started it).
constexpr int kKilledBySignal = -2;
int RunProgram(const std::vector<std::string>& command, std::string* message);

// Runs the report script (evaluation_report.py), whose own lines say what it wrote, and
// otherwise logs one line that says what is missing or failed and that the tables were
// written (python not found; matplotlib or numpy missing: install
// python3-matplotlib and python3-numpy; the script missing; the script ended by a
// signal; any other failure with its exit status). Returns true on success; a failure
// is never fatal for the caller.
bool RunReportScript(const std::string& python, const std::string& script,
                     const std::vector<std::string>& arguments, std::ostream& log);

}  // namespace aqs

#endif  // AQS_JOBS_REPORT_SCRIPT_H_
